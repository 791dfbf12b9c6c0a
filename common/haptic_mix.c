/* haptic_mix.c - the mixing law (haptic_mix.h). */
#include "haptic_mix.h"

#include <math.h>

uint32_t haptic_mix_blocks(uint32_t frames) { return (frames + HAPTIC_MIX_PEAK_BLOCK - 1) / HAPTIC_MIX_PEAK_BLOCK; }

void haptic_mix_block_peaks(const int16_t *signal, uint32_t frames, uint32_t channels, uint16_t *out)
{
    const uint32_t blocks = haptic_mix_blocks(frames);
    for (uint32_t i = 0; i < blocks * channels; i++)
        out[i] = 0;
    for (uint32_t n = 0; n < frames; n++) {
        uint16_t *row = out + (n / HAPTIC_MIX_PEAK_BLOCK) * channels;
        for (uint32_t c = 0; c < channels; c++) {
            int v = signal[(uint64_t)n * channels + c];
            uint16_t a = (uint16_t)(v < 0 ? -v : v);
            if (a > row[c])
                row[c] = a;
        }
    }
}

uint32_t haptic_mix_peak_bound(const uint16_t *const *envelopes, uint32_t count, uint32_t blocks, uint32_t channels)
{
    uint32_t best = 0;
    for (uint32_t b = 0; b < blocks; b++)
        for (uint32_t c = 0; c < channels; c++) {
            uint32_t s = 0;
            for (uint32_t k = 0; k < count; k++)
                s += envelopes[k][b * channels + c];
            if (s > best)
                best = s;
        }
    return best;
}

void haptic_mix_gain_of(double (*gram)(const void *ctx, uint32_t i, uint32_t j), const void *ctx, uint32_t count,
                        uint32_t peak_bound, double level, double gain_limit, haptic_mix_gain *out)
{
    haptic_mix_gain_in_range_of(gram, ctx, count, peak_bound, level, NULL, gain_limit, out);
}

void haptic_mix_gain_in_range_of(double (*gram)(const void *ctx, uint32_t i, uint32_t j), const void *ctx,
                                 uint32_t count, uint32_t peak_bound, double level, const haptic_gain_range *range,
                                 double gain_limit, haptic_mix_gain *out)
{
    double e_ref = 0.0, e_sum = 0.0;
    for (uint32_t i = 0; i < count; i++)
        for (uint32_t j = 0; j < count; j++) {
            const double g = gram(ctx, i, j);
            e_sum += g;
            if (i == j)
                e_ref += g;
        }
    e_ref /= count;
    /* e_sum is the energy of the unscaled sum, >= 0; it is 0 only if the
     * signals cancel exactly, and then the mix is silent whatever g is. */
    out->energy = e_sum > 0.0 ? sqrt(e_ref / e_sum) : 0.0;
    out->peak = peak_bound > 0 ? 32767.0 / peak_bound : gain_limit;
    double g = level * out->energy;
    if (range && out->energy > 0.0) /* energy 0: the foci cancel, silent at any gain */
        g = haptic_gain_range_clamp(range, g);
    if (g > out->peak)
        g = out->peak;
    if (g > gain_limit)
        g = gain_limit;
    out->gain = g;
    out->gain_q30 = haptic_mix_q30(g);
}

int64_t haptic_mix_q30(double gain) { return (int64_t)llround(gain * (double)(1 << HAPTIC_MIX_GAIN_FRAC_BITS)); }

/* Right shifts of negative int64 are arithmetic on every compiler we build
 * with (GCC, Clang), so (x + half) >> s rounds half up. */
uint32_t haptic_mix_to_s16(const int64_t *acc, int16_t *out, uint32_t n)
{
    uint32_t clipped = 0;
    for (uint32_t i = 0; i < n; i++) {
        int64_t v = (acc[i] + ((int64_t)1 << (HAPTIC_MIX_GAIN_FRAC_BITS - 1))) >> HAPTIC_MIX_GAIN_FRAC_BITS;
        if (v > INT16_MAX) {
            v = INT16_MAX;
            clipped++;
        } else if (v < INT16_MIN) {
            v = INT16_MIN;
            clipped++;
        }
        out[i] = (int16_t)v;
    }
    return clipped;
}

uint32_t haptic_mix_to_s32(const int64_t *acc, int32_t *out, uint32_t n)
{
    const int shift = HAPTIC_MIX_GAIN_FRAC_BITS - 16;
    uint32_t clipped = 0;
    for (uint32_t i = 0; i < n; i++) {
        int64_t v = (acc[i] + ((int64_t)1 << (shift - 1))) >> shift;
        if (v > INT32_MAX) {
            v = INT32_MAX;
            clipped++;
        } else if (v < INT32_MIN) {
            v = INT32_MIN;
            clipped++;
        }
        out[i] = (int32_t)v;
    }
    return clipped;
}
