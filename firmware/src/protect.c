/* protect.c - the exciters' ratings (protect.h). */
#include "protect.h"

#include <errno.h>
#include <math.h>
#include <string.h>

int hd_protect_init(struct hd_protect *pr, uint32_t channels, const struct hd_exciter_rating *rating,
                    double full_scale_v, uint32_t rate_hz)
{
    memset(pr, 0, sizeof *pr);
    if (channels == 0 || channels > HD_MAX_CHANNELS || !(full_scale_v > 0) || !isfinite(full_scale_v) || !rate_hz)
        return -EINVAL;
    pr->channels = channels;
    for (uint32_t c = 0; c < channels; c++) {
        const struct hd_exciter_rating *r = &rating[c];
        if (!(r->rated_power_w >= 0) || !isfinite(r->rated_power_w))
            return -EINVAL;
        if (r->rated_power_w > 0 &&
            (!(r->impedance_ohm > 0) || !isfinite(r->impedance_ohm) || !(r->tau_s > 0) || !isfinite(r->tau_s)))
            return -EINVAL;
        pr->rating[c] = *r;
        if (r->rated_power_w > 0) {
            const double v = full_scale_v / 32767.0;
            pr->joules_per_count2[c] = v * v / r->impedance_ohm / rate_hz;
        }
    }
    return 0;
}

void hd_protect_voice_cost(const struct hd_protect *pr, uint32_t c, double root, double gain, struct hd_voice_cost *out)
{
    *out = (struct hd_voice_cost){0.0, 0.0, INFINITY};
    if (c >= pr->channels || pr->rating[c].rated_power_w <= 0)
        return;
    out->joules = gain * root * gain * root * pr->joules_per_count2[c];
    out->heat_step_w = out->joules / pr->rating[c].tau_s;
    out->sustained_hz = out->joules > 0 ? pr->rating[c].rated_power_w / out->joules : INFINITY;
}

double hd_protect_heat_w(const struct hd_protect *pr, uint32_t c, uint64_t now_ns)
{
    if (c >= pr->channels || pr->rating[c].rated_power_w <= 0 || pr->heat_w[c] == 0.0)
        return 0.0;
    const double dt = now_ns > pr->t_ns ? (double)(now_ns - pr->t_ns) * 1e-9 : 0.0;
    return pr->heat_w[c] * exp(-dt / pr->rating[c].tau_s);
}

/* Every channel's heat brought to now_ns. */
static void advance(struct hd_protect *pr, uint64_t now_ns)
{
    for (uint32_t c = 0; c < pr->channels; c++)
        pr->heat_w[c] = hd_protect_heat_w(pr, c, now_ns);
    if (now_ns > pr->t_ns)
        pr->t_ns = now_ns;
}

void hd_protect_played(struct hd_protect *pr, const int64_t *acc, uint32_t frames, uint32_t stride, uint64_t end_ns)
{
    advance(pr, end_ns);
    const double unit = 1.0 / (double)((int64_t)1 << 30);
    for (uint32_t c = 0; c < pr->channels; c++) {
        if (pr->rating[c].rated_power_w <= 0)
            continue;
        double e = 0;
        for (uint32_t n = 0; n < frames; n++) {
            const double x = (double)acc[(uint64_t)n * stride + c] * unit;
            e += x * x;
        }
        /* At the period's end with weight 1: at least what the energy,
         * delivered during the period, left. */
        pr->heat_w[c] += e * pr->joules_per_count2[c] / pr->rating[c].tau_s;
    }
}

double hd_protect_admit(struct hd_protect *pr, uint64_t now_ns, const double *playing_root, const double *new_root,
                        double gain, double min_gain)
{
    advance(pr, now_ns);
    double g = gain;
    for (uint32_t c = 0; c < pr->channels; c++) {
        if (pr->rating[c].rated_power_w <= 0 || new_root[c] <= 0)
            continue;
        /* heat + (P + g N)^2 k <= rated, k = J / tau: the largest g. */
        const double k = pr->joules_per_count2[c] / pr->rating[c].tau_s;
        const double room = pr->rating[c].rated_power_w - pr->heat_w[c];
        const double reach = room > 0 ? sqrt(room / k) : 0.0; /* the largest root energy still allowed */
        const double g_max = reach > playing_root[c] ? (reach - playing_root[c]) / new_root[c] : 0.0;
        if (g_max < g)
            g = g_max;
    }
    if (g < gain) {
        if (g < min_gain || g < gain * HD_PROTECT_SKIP_BELOW) {
            pr->skipped++;
            return 0.0;
        }
        pr->attenuated++;
    }
    return g;
}
