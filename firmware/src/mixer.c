/* mixer.c - gain (energy normalization + peak limit) and format conversion.
 * Everything here is real-time safe: no allocation, no lock, no I/O. */
#include "mixer.h"

#include <errno.h>
#include <math.h>

double hd_mixer_sum_energy(const struct hd_program *p, const uint32_t *index, uint32_t count)
{
    double e = 0.0;
    for (uint32_t i = 0; i < count; i++)
        for (uint32_t j = 0; j < count; j++)
            e += hd_program_gram(p, index[i], index[j]);
    return e;
}

static uint32_t peak_bound(const struct hd_program *p, const uint32_t *index, uint32_t count)
{
    const uint32_t C = p->channel_count;
    uint32_t best = 0;
    for (uint32_t b = 0; b < p->blocks; b++)
        for (uint32_t c = 0; c < C; c++) {
            uint32_t s = 0;
            for (uint32_t k = 0; k < count; k++)
                s += p->block_peak[((size_t)index[k] * p->blocks + b) * C + c];
            if (s > best)
                best = s;
        }
    return best;
}

int hd_mixer_gain(const struct hd_program *p, double gain_limit, struct hd_mix *m)
{
    if (m->count == 0 || m->count > HD_MAX_VOICE_FOCI)
        return -EINVAL;
    double e_ref = 0.0;
    for (uint32_t k = 0; k < m->count; k++) {
        if (m->index[k] >= p->focus_count)
            return -EINVAL;
        e_ref += hd_program_gram(p, m->index[k], m->index[k]);
    }
    e_ref /= m->count;
    double e_sum = hd_mixer_sum_energy(p, m->index, m->count);
    /* e_sum is the energy of the unscaled sum, >= 0; it is 0 only if the
     * signals cancel exactly, and then the mix is silent whatever g is. */
    m->gain_energy = e_sum > 0.0 ? sqrt(e_ref / e_sum) : 0.0;
    uint32_t peak = peak_bound(p, m->index, m->count);
    m->gain_peak = peak > 0 ? 32767.0 / peak : gain_limit;
    double g = m->gain_energy;
    if (g > m->gain_peak)
        g = m->gain_peak;
    if (g > gain_limit)
        g = gain_limit;
    m->gain = g;
    m->gain_q30 = (int64_t)llround(g * (double)(1 << HD_GAIN_FRAC_BITS));
    return 0;
}

/* Right shifts of negative int64 are arithmetic on every compiler we build
 * with (GCC, Clang), so (x + half) >> s rounds half up. */
uint32_t hd_mixer_to_s16(const int64_t *acc, int16_t *out, uint32_t n)
{
    uint32_t clipped = 0;
    for (uint32_t i = 0; i < n; i++) {
        int64_t v = (acc[i] + ((int64_t)1 << (HD_GAIN_FRAC_BITS - 1))) >> HD_GAIN_FRAC_BITS;
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

/* S32 full scale is the table's full scale times 2^16. */
uint32_t hd_mixer_to_s32(const int64_t *acc, int32_t *out, uint32_t n)
{
    const int shift = HD_GAIN_FRAC_BITS - 16;
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
