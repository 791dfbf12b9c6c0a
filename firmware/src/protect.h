/* protect.h - the exciters' ratings, enforced on every voice.
 *
 * Each device channel drives one exciter through an amplifier whose output
 * is `full_scale_v` (peak volts) at digital full scale. A sample x (table
 * counts, full scale 32767) puts x^2 (V/32767)^2 / Z watts into the coil
 * (resistive model: the nominal impedance Z). The coil heats and cools with
 * one time constant tau (first-order thermal model): its heat, in watts of
 * steady power, is the power averaged with an exponential window of tau,
 *     heat(t) = integral p(s) exp(-(t - s) / tau) ds / tau,
 * and the rating holds while heat <= rated_power_w (the data sheet's RMS
 * power): a steady drive at the rated power sits at the limit, a short burst
 * may be stronger as long as the average over tau stays within it.
 *
 * The heat is measured, not assumed: every rendered period's energy per
 * channel (before the device format's saturation) enters it at the period's
 * end (hd_protect_played), so overlapping voices count with their true sum,
 * coherent or not. A new voice is admitted against a bound of the future:
 * the energy still to come from the voices playing and from the new one,
 * by Minkowski's inequality at most (sum_v g_v sqrt(E_v,c))^2 on channel c
 * (E_v,c the voice's whole energy per gain^2, a bound of what remains), so
 *     heat_now + (R_playing + g R_new)^2 J / tau <= rated_power_w
 * (J: joules per count^2) keeps the heat within the rating at every later
 * time whatever the voices' phases, since every later weight is at most 1.
 * When the voice's gain would break it, it is lowered to the largest gain
 * that keeps it; below `min_gain` (the caller's floor: a voice that cannot
 * be felt is not worth the heat; the player's is the bottom of the voice's
 * safe range, format 1.3), or below HD_PROTECT_SKIP_BELOW of the gain
 * asked (-60 dB: nothing left to play), the voice is skipped. Both counted.
 *
 * Pure and real-time safe: no allocation, no lock, no I/O. Times are the
 * device timeline's (frames / rate). */
#ifndef HD_PROTECT_H
#define HD_PROTECT_H

#include "hd_defs.h"

#include <stdint.h>

#define HD_PROTECT_SKIP_BELOW 1e-3
#define HD_PROTECT_DEFAULT_TAU_S 2.0 /* when the data sheet gives no thermal time constant */

struct hd_exciter_rating {
    double rated_power_w; /* RMS power rating; 0: channel not protected */
    double impedance_ohm; /* nominal impedance */
    double tau_s;         /* the coil's thermal time constant */
};

struct hd_protect {
    uint32_t channels;
    struct hd_exciter_rating rating[HD_MAX_CHANNELS];
    double joules_per_count2[HD_MAX_CHANNELS]; /* (V/32767)^2 / Z / rate: one sample's energy per count^2 */
    double heat_w[HD_MAX_CHANNELS];            /* heat at t_ns */
    uint64_t t_ns;
    uint64_t attenuated, skipped;
};

/* Ratings per device channel; full_scale_v > 0. Returns 0 or -EINVAL (a
 * rating that is negative or not finite, an impedance <= 0 on a protected
 * channel, a time constant <= 0). */
int hd_protect_init(struct hd_protect *pr, uint32_t channels, const struct hd_exciter_rating *rating,
                    double full_scale_v, uint32_t rate_hz);

/* What one voice costs coil c: a drive of root energy `root` (sqrt of its
 * sum of s^2 on that channel, table counts) played at `gain` puts
 * `joules` = (gain root)^2 J into it (J: the channel's joules per count^2),
 * raises its heat by `heat_step_w` = joules / tau when short beside tau,
 * and the rating sustains `sustained_hz` = rated_power_w / joules such
 * voices a second for ever (the heat's long-run average is the mean
 * power). An unprotected channel costs 0 and sustains +infinity. */
struct hd_voice_cost {
    double joules, heat_step_w, sustained_hz;
};
void hd_protect_voice_cost(const struct hd_protect *pr, uint32_t c, double root, double gain,
                           struct hd_voice_cost *out);

/* The heat of channel c at now_ns (watts of steady power). */
double hd_protect_heat_w(const struct hd_protect *pr, uint32_t c, uint64_t now_ns);

/* What was played: `frames` rows of `stride` Q30 accumulators (table counts
 * * 2^30, device channel order), ending at end_ns. */
void hd_protect_played(struct hd_protect *pr, const int64_t *acc, uint32_t frames, uint32_t stride, uint64_t end_ns);

/* Admit a voice at now_ns. Per device channel c: playing_root[c] =
 * sum over the voices still playing of gain_v sqrt(E_v,c), new_root[c] =
 * sqrt(E_new,c) at gain 1 (table counts). Returns the gain the voice may
 * play at (<= gain; 0: skipped). */
double hd_protect_admit(struct hd_protect *pr, uint64_t now_ns, const double *playing_root, const double *new_root,
                        double gain, double min_gain);

#endif
