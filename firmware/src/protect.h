/* protect.h - the exciters' ratings, enforced on every voice.
 *
 * Each device channel drives one exciter through an amplifier whose output
 * is `full_scale_v` (peak volts) at digital full scale. A sample x (table
 * counts, full scale 32767) puts x^2 (V/32767)^2 / Z watts into the coil
 * (resistive model: the nominal impedance Z). The coil heats and cools with
 * one time constant tau (first-order thermal model): its heat, in watts of
 * steady power, is the power averaged with an exponential window of tau,
 *     heat(t) = heat(t0) exp(-(t - t0) / tau) + (energy delivered since) / tau,
 * and the rating holds while heat <= rated_power_w (the data sheet's RMS
 * power): a steady drive at the rated power sits at the limit, a short burst
 * may be stronger as long as the average over tau stays within it.
 *
 * A voice is admitted at its start with the whole of its energy counted at
 * once (an upper bound of the heat it causes, whenever it is delivered),
 * bounded per channel by Cauchy-Schwarz for a mix of K foci:
 *     E_c(g) <= g^2 (sum_k sqrt(E_kc))^2,  E_kc = sum_n s_k[n][c]^2,
 * so no combination of touches can heat a coil past its rating. When the
 * voice's gain would, it is lowered to the largest gain that fits; when that
 * is below `min_gain` (the caller's floor: a voice that cannot be felt is not
 * worth the heat), or below HD_PROTECT_SKIP_BELOW of the gain asked (-60 dB:
 * nothing left to play), the voice is skipped. Both are counted.
 *
 * Pure and real-time safe: no allocation, no lock, no I/O. */
#ifndef HD_PROTECT_H
#define HD_PROTECT_H

#include "hd_defs.h"

#include <stdint.h>

#define HD_PROTECT_SKIP_BELOW 1e-3
#define HD_PROTECT_DEFAULT_TAU_S 2.0  /* when the data sheet gives no thermal time constant */

struct hd_exciter_rating {
    double rated_power_w;   /* RMS power rating; 0: channel not protected */
    double impedance_ohm;   /* nominal impedance */
    double tau_s;           /* the coil's thermal time constant */
};

struct hd_protect {
    uint32_t channels;
    double full_scale_v;
    uint32_t rate_hz;
    struct hd_exciter_rating rating[HD_MAX_CHANNELS];
    double joules_per_count2[HD_MAX_CHANNELS]; /* (V/32767)^2 / Z / rate: one sample's energy per count^2 */
    double heat_w[HD_MAX_CHANNELS];            /* heat state at t_ns */
    uint64_t t_ns;
    uint64_t attenuated, skipped;
};

/* Ratings per device channel; full_scale_v > 0. Returns 0 or -EINVAL (a
 * rating that is negative or not finite, an impedance <= 0 on a protected
 * channel, a time constant <= 0). */
int hd_protect_init(struct hd_protect *pr, uint32_t channels, const struct hd_exciter_rating *rating,
                    double full_scale_v, uint32_t rate_hz);

/* The heat of channel c at now_ns (watts of steady power). */
double hd_protect_heat_w(const struct hd_protect *pr, uint32_t c, uint64_t now_ns);

/* Admit a voice at now_ns: root_energy[c] = sum_k sqrt(E_kc) for device
 * channel c (table counts; 0 for a channel the voice does not drive), at the
 * requested gain. Returns the gain it may play at (<= gain; 0: skipped) and
 * commits the heat of that gain. */
double hd_protect_admit(struct hd_protect *pr, uint64_t now_ns, const double *root_energy, double gain,
                        double min_gain);

#endif
