/* mixer.c - a voice's gain by the mixing law (common/haptic_mix.h) from the
 * program's Gram matrix and peak envelopes. Real-time safe: no allocation,
 * no lock, no I/O. */
#include "mixer.h"

#include <errno.h>

double hd_mixer_sum_energy(const struct hd_program *p, const uint32_t *index, uint32_t count)
{
    double e = 0.0;
    for (uint32_t i = 0; i < count; i++)
        for (uint32_t j = 0; j < count; j++)
            e += hd_program_gram(p, index[i], index[j]);
    return e;
}

struct gram_ctx {
    const struct hd_program *p;
    const uint32_t *index;
};

static double gram_of(const void *ctx, uint32_t i, uint32_t j)
{
    const struct gram_ctx *g = ctx;
    return hd_program_gram(g->p, g->index[i], g->index[j]);
}

int hd_mixer_gain(const struct hd_program *p, double level, double gain_limit, struct hd_mix *m)
{
    return hd_mixer_gain_in_range(p, level, NULL, gain_limit, m);
}

int hd_mixer_gain_in_range(const struct hd_program *p, double level, const haptic_gain_range *range, double gain_limit,
                           struct hd_mix *m)
{
    if (m->count == 0 || m->count > HD_MAX_VOICE_FOCI)
        return -EINVAL;
    const uint16_t *envelopes[HD_MAX_VOICE_FOCI];
    const size_t per_focus = (size_t)p->blocks * p->channel_count;
    for (uint32_t k = 0; k < m->count; k++) {
        if (m->index[k] >= p->focus_count)
            return -EINVAL;
        envelopes[k] = p->block_peak + m->index[k] * per_focus;
    }
    const struct gram_ctx ctx = {p, m->index};
    const uint32_t peak_bound = haptic_mix_peak_bound(envelopes, m->count, p->blocks, p->channel_count);
    haptic_mix_gain g;
    haptic_mix_gain_in_range_of(gram_of, &ctx, m->count, peak_bound, level, range, gain_limit, &g);
    m->gain_energy = g.energy;
    m->gain_peak = g.peak;
    m->gain = g.gain;
    m->gain_q30 = g.gain_q30;
    return 0;
}
