/* exciter_report.c - what each focus costs the exciters (exciter_report.h). */
#include "exciter_report.h"

#include "protect.h"

#include <errno.h>
#include <math.h>

/* The busiest exciter of focus f at gain g: the one that sustains the
 * fewest such touches a second. */
static uint32_t busiest(const struct hd_protect *pr, const struct hd_program *p, uint32_t f, double g,
                        struct hd_voice_cost *cost)
{
    uint32_t worst = 0;
    for (uint32_t c = 0; c < p->channel_count; c++) {
        struct hd_voice_cost k;
        hd_protect_voice_cost(pr, c, p->root_energy[(size_t)f * p->channel_count + c], g, &k);
        if (c == 0 || k.sustained_hz < cost->sustained_hz) {
            *cost = k;
            worst = c;
        }
    }
    return worst;
}

int hd_exciter_report(const struct hd_program *p, const struct hd_board *b, const char *board_path, FILE *out,
                      char err[HD_ERR_MAX])
{
    struct hd_exciter_rating rating[HD_MAX_CHANNELS];
    struct hd_protect pr;
    if (!hd_board_exciter_ratings(b, rating, p->channel_count)) {
        snprintf(err, HD_ERR_MAX, "%s: no [exciters] ratings to compare the drives with", board_path);
        return -EINVAL;
    }
    if (hd_protect_init(&pr, p->channel_count, rating, b->amp_full_scale_v, b->rate_hz) != 0) {
        snprintf(err, HD_ERR_MAX, "%s: the [exciters] ratings or [amplifier] full_scale_v are out of range",
                 board_path);
        return -EINVAL;
    }
    fprintf(out,
            "exciters     %s: amplifier %.3g V at full scale; per focus, on its busiest exciter: one touch's "
            "energy, the heat it adds, and the touches a second its rating sustains\n",
            board_path, b->amp_full_scale_v);
    double fewest = INFINITY;
    uint32_t fewest_id = 0;
    for (uint32_t f = 0; f < p->focus_count; f++) {
        haptic_focus_info info;
        haptic_table_focus(&p->table, f, &info);
        struct hd_voice_cost cost = {0};
        const uint32_t c = busiest(&pr, p, f, 1.0, &cost);
        fprintf(out,
                "  focus %u: exciter %u (%.3g W rated, tau %.3g s): %.4g mJ a touch, heat +%.4g mW, %.4g touches/s",
                info.id, c, rating[c].rated_power_w, rating[c].tau_s, 1e3 * cost.joules, 1e3 * cost.heat_step_w,
                cost.sustained_hz);
        if (cost.heat_step_w > rating[c].rated_power_w)
            fprintf(out, " (one touch alone exceeds the rating: it always plays lowered)");
        if (cost.sustained_hz < fewest) {
            fewest = cost.sustained_hz;
            fewest_id = info.id;
        }
        if (p->range && isinf(p->range[f].hi)) {
            fprintf(out, "; its safe range has no top");
        } else if (p->range) {
            const double top = haptic_gain_range_clamp(&p->range[f], INFINITY);
            struct hd_voice_cost at_top = {0};
            busiest(&pr, p, f, top, &at_top);
            fprintf(out, "; at the top of its safe range (%+.1f dB) %.4g mJ, %.4g touches/s", 20 * log10(top),
                    1e3 * at_top.joules, at_top.sustained_hz);
        }
        fputc('\n', out);
    }
    fprintf(out,
            "  the busiest focus (%u) sustains %.4g touches/s at the table's level; faster touches are lowered "
            "or skipped by the exciters' protection\n",
            fewest_id, fewest);
    return 0;
}
