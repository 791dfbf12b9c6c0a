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
    pr->full_scale_v = full_scale_v;
    pr->rate_hz = rate_hz;
    for (uint32_t c = 0; c < channels; c++) {
        const struct hd_exciter_rating *r = &rating[c];
        if (!(r->rated_power_w >= 0) || !isfinite(r->rated_power_w))
            return -EINVAL;
        if (r->rated_power_w > 0 && (!(r->impedance_ohm > 0) || !isfinite(r->impedance_ohm) || !(r->tau_s > 0) ||
                                     !isfinite(r->tau_s)))
            return -EINVAL;
        pr->rating[c] = *r;
        if (r->rated_power_w > 0) {
            const double v = full_scale_v / 32767.0;
            pr->joules_per_count2[c] = v * v / r->impedance_ohm / rate_hz;
        }
    }
    return 0;
}

static double decayed(const struct hd_protect *pr, uint32_t c, uint64_t now_ns)
{
    if (pr->heat_w[c] == 0.0)
        return 0.0;
    const double dt = now_ns > pr->t_ns ? (double)(now_ns - pr->t_ns) * 1e-9 : 0.0;
    return pr->heat_w[c] * exp(-dt / pr->rating[c].tau_s);
}

double hd_protect_heat_w(const struct hd_protect *pr, uint32_t c, uint64_t now_ns)
{
    return c < pr->channels && pr->rating[c].rated_power_w > 0 ? decayed(pr, c, now_ns) : 0.0;
}

double hd_protect_admit(struct hd_protect *pr, uint64_t now_ns, const double *root_energy, double gain,
                        double min_gain)
{
    double g = gain;
    for (uint32_t c = 0; c < pr->channels; c++) {
        pr->heat_w[c] = hd_protect_heat_w(pr, c, now_ns);
        if (pr->rating[c].rated_power_w <= 0 || root_energy[c] <= 0)
            continue;
        /* Heat of the voice at gain 1: its energy over tau. */
        const double per_g2 = root_energy[c] * root_energy[c] * pr->joules_per_count2[c] / pr->rating[c].tau_s;
        const double room = pr->rating[c].rated_power_w - pr->heat_w[c];
        const double g_max = room > 0 ? sqrt(room / per_g2) : 0.0;
        if (g_max < g)
            g = g_max;
    }
    if (now_ns > pr->t_ns)
        pr->t_ns = now_ns;
    if (g < gain) {
        if (g < min_gain || g < gain * HD_PROTECT_SKIP_BELOW) {
            pr->skipped++;
            return 0.0;
        }
        pr->attenuated++;
    }
    for (uint32_t c = 0; c < pr->channels; c++)
        if (pr->rating[c].rated_power_w > 0 && root_energy[c] > 0)
            pr->heat_w[c] += g * g * root_energy[c] * root_energy[c] * pr->joules_per_count2[c] / pr->rating[c].tau_s;
    return g;
}
