/* mixer.h - energy-normalized superposition of foci, in fixed point.
 *
 * For the selected foci S (K of them, signals s_f[n][c] in table counts) the
 * mix is y[n][c] = g * sum_{f in S} s_f[n][c]. Energy held constant: the
 * total drive energy of the mix, summed over all exciter channels and all
 * samples, E_mix = g^2 * sum_{f,f' in S} G[f][f'], equals E_ref, the mean
 * energy of the selected foci each played alone at table full scale:
 *     E_ref = (1/K) sum_{f in S} G[f][f],   g_energy = sqrt(E_ref / sum_{f,f'} G[f][f']).
 * One focus plays exactly as stored (g = 1). K foci of equal energy that are
 * uncorrelated (G[f][f'] = 0 for f != f') get g = 1/sqrt(K): the amplitude
 * per focus falls as 1/sqrt(K) and each focus receives 1/K of the energy.
 * Correlated foci (neighbours) get less, anti-correlated more.
 * Then two limits, in this order, and g = min(g_energy, g_peak, gain_limit):
 *   g_peak = 32767 / P(S), P(S) = max over blocks b and channels c of
 *            sum_{f in S} max_{n in b} |s_f[n][c]| (blocks of HD_PEAK_BLOCK
 *            frames): an upper bound of the peak of the unscaled sum, so a
 *            voice never clips; cost O(K * C * N / HD_PEAK_BLOCK);
 *   gain_limit from the board ([mixer] gain_limit, default 1).
 * When a limit binds, E_mix falls below E_ref (reported in hd_mix).
 */
#ifndef HD_MIXER_H
#define HD_MIXER_H

#include "program.h"

#include <stdint.h>

#define HD_MAX_VOICE_FOCI 32u
#define HD_GAIN_FRAC_BITS 30  /* gain in Q30: g < 16 and |sum s| <= 2^25 keep products < 2^60 */

struct hd_mix {
    uint32_t count;
    uint32_t index[HD_MAX_VOICE_FOCI]; /* table focus indices, distinct */
    double gain_energy, gain_peak, gain;
    int64_t gain_q30;                  /* round(gain * 2^30) */
};

/* Compute the gain for the foci in m->index[0..count). Returns 0, or
 * -EINVAL if count is 0 or an index is out of range. */
int hd_mixer_gain(const struct hd_program *p, double gain_limit, struct hd_mix *m);

/* Energy sum_{f,f' in S} G[f][f'] of the unscaled sum (O(K^2) from the Gram matrix). */
double hd_mixer_sum_energy(const struct hd_program *p, const uint32_t *index, uint32_t count);

/* Convert accumulated Q30 samples (table counts * 2^30) to the device format
 * with round-half-up and saturation. Returns how many samples saturated. */
uint32_t hd_mixer_to_s16(const int64_t *acc, int16_t *out, uint32_t n);
uint32_t hd_mixer_to_s32(const int64_t *acc, int32_t *out, uint32_t n);

#endif
