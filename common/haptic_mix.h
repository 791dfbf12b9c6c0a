/* haptic_mix.h - the mixing law: how several foci of a table are played
 * together. One home for the rule the device plays (hapticd's mixer) and the
 * desktop tool judges (calibgen's multi-touch verification), so the two
 * agree sample for sample.
 *
 * For the selected foci S (K of them, drives s_f[n][c] in table counts) the
 * mix is y[n][c] = g * sum_{f in S} s_f[n][c], with
 *   g = min(level g_energy, g_peak, gain_limit),
 *   g_energy = sqrt(E_ref / E_sum): E_ref = (1/K) sum_{f in S} G[f][f] is the
 *     mean energy of the foci played alone, E_sum = sum_{f,f' in S} G[f][f']
 *     the energy of the unscaled sum (G: the table's Gram matrix, exact
 *     integer sums over every sample and channel). The mix carries the
 *     energy of one focus: one focus plays as stored, K uncorrelated foci of
 *     equal energy get 1/sqrt(K) each;
 *   g_peak = 32767 / P(S), P(S) = max over blocks b and channels c of
 *     sum_{f in S} max_{n in b} |s_f[n][c]| (blocks of HAPTIC_MIX_PEAK_BLOCK
 *     frames): a bound of the unscaled sum's peak, so a mix never clips;
 *   level: the user's intensity (linear; 1 = the table's own level: hapticd's
 *     intensity control, calibgen judges at 1);
 *   gain_limit: the board's [mixer] gain_limit (calibgen judges at 1).
 * The gain is applied in fixed point, Q30 (haptic_mix_q30), and the
 * accumulated sum rounded half up and saturated to the device format
 * (haptic_mix_to_s16 / _s32). Real-time safe: no allocation, no lock. */
#ifndef HAPTIC_MIX_H
#define HAPTIC_MIX_H

#include "haptic_table.h" /* haptic_gain_range */

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define HAPTIC_MIX_PEAK_BLOCK 64u    /* frames per block of the peak envelope */
#define HAPTIC_MIX_GAIN_FRAC_BITS 30 /* gain in Q30: g < 16 and |sum s| <= 2^25 keep products < 2^60 */

/* Blocks of the peak envelope of a signal of `frames` frames: ceil(frames / 64). */
uint32_t haptic_mix_blocks(uint32_t frames);

/* The peak envelope of one drive, signal[frame][channel]: out[b * channels + c]
 * = max |signal[n][c]| over the frames n of block b (<= 32768). out holds
 * haptic_mix_blocks(frames) * channels values. */
void haptic_mix_block_peaks(const int16_t *signal, uint32_t frames, uint32_t channels, uint16_t *out);

/* P(S): envelopes[k] is focus k's envelope (blocks * channels values). */
uint32_t haptic_mix_peak_bound(const uint16_t *const *envelopes, uint32_t count, uint32_t blocks, uint32_t channels);

typedef struct haptic_mix_gain {
    double energy, peak, gain; /* g_energy, g_peak, and g = the smallest of level g_energy, g_peak, the limit */
    int64_t gain_q30;          /* round(g * 2^30), what is applied */
} haptic_mix_gain;

/* The law: gram(ctx, i, j) is G[f_i][f_j] for the K selected foci
 * (i, j < count), peak_bound their P(S). count >= 1, level >= 0. */
void haptic_mix_gain_of(double (*gram)(const void *ctx, uint32_t i, uint32_t j), const void *ctx, uint32_t count,
                        uint32_t peak_bound, double level, double gain_limit, haptic_mix_gain *out);

/* The same law with a safe range (haptic_table.h, format 1.3; NULL: none):
 * the gain every focus of the voice is played at, level x g_energy, is
 * clamped into it (haptic_gain_range_clamp) before the peak limit and
 * gain_limit, which only lower it: g = min(clamp(level g_energy), g_peak,
 * gain_limit). One focus has g_energy = 1: its level itself is clamped. */
void haptic_mix_gain_in_range_of(double (*gram)(const void *ctx, uint32_t i, uint32_t j), const void *ctx,
                                 uint32_t count, uint32_t peak_bound, double level, const haptic_gain_range *range,
                                 double gain_limit, haptic_mix_gain *out);

/* A gain in the fixed point it is applied in: round(g * 2^30). */
int64_t haptic_mix_q30(double gain);

/* Accumulated Q30 samples (table counts * 2^30) to the device format, rounded
 * half up and saturated. Return how many samples saturated. S32 full scale
 * is the table's full scale times 2^16. */
uint32_t haptic_mix_to_s16(const int64_t *acc, int16_t *out, uint32_t n);
uint32_t haptic_mix_to_s32(const int64_t *acc, int32_t *out, uint32_t n);

#ifdef __cplusplus
}
#endif

#endif
