/* mixer.h - the device's side of the mixing law (common/haptic_mix.h: the
 * energy normalization, the peak limit, Q30 and the device formats): the gain
 * of a voice from the program's Gram matrix and peak envelopes. */
#ifndef HD_MIXER_H
#define HD_MIXER_H

#include "program.h"

#include <haptic_mix.h>

#include <stdint.h>

struct hd_mix {
    uint32_t count;
    uint32_t index[HD_MAX_VOICE_FOCI]; /* table focus indices, distinct */
    double gain_energy, gain_peak, gain;
    int64_t gain_q30; /* round(gain * 2^30) */
};

/* Compute the gain for the foci in m->index[0..count) at the user's level
 * (linear, 1 = the table's). Returns 0, or -EINVAL if count is 0 or an
 * index is out of range. */
int hd_mixer_gain(const struct hd_program *p, double level, double gain_limit, struct hd_mix *m);

/* The same within the voice's safe range (hd_program_voice_range; NULL:
 * none, as hd_mixer_gain): the law with the range
 * (haptic_mix_gain_in_range_of). Real-time safe. */
int hd_mixer_gain_in_range(const struct hd_program *p, double level, const haptic_gain_range *range, double gain_limit,
                           struct hd_mix *m);

/* Energy sum_{f,f' in S} G[f][f'] of the unscaled sum (O(K^2) from the Gram matrix). */
double hd_mixer_sum_energy(const struct hd_program *p, const uint32_t *index, uint32_t count);

/* The device formats: haptic_mix_to_s16 / haptic_mix_to_s32 (haptic_mix.h). */

#endif
