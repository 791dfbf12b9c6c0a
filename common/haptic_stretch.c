/* haptic_stretch.c - speed compensation of a drive (haptic_stretch.h). */
#include "haptic_stretch.h"

#include <errno.h>
#include <math.h>
#include <soxr.h>
#include <stdlib.h>
#include <string.h>

static int ratio_ok(double r) { return r >= HAPTIC_STRETCH_MIN_RATIO && r <= HAPTIC_STRETCH_MAX_RATIO; }

uint32_t haptic_stretch_frames(uint32_t frames, double speed_ratio)
{
    if (!ratio_ok(speed_ratio))
        return 0;
    if (speed_ratio == 1.0)
        return frames;
    /* The stretched signal lasts as long as the input's frames do at the new
     * speed; a hair of tolerance keeps an exact quotient from rounding up. */
    return (uint32_t)ceil((double)frames / speed_ratio - 1e-9);
}

int haptic_stretch(const int16_t *in, uint32_t frames, uint32_t channels, double speed_ratio, int16_t *out,
                   uint64_t *clipped)
{
    if (!in || !out || channels == 0 || frames == 0 || !ratio_ok(speed_ratio))
        return -EINVAL;
    const uint32_t n_out = haptic_stretch_frames(frames, speed_ratio);
    if (speed_ratio == 1.0) {
        memcpy(out, in, (size_t)frames * channels * sizeof *in);
        return 0;
    }
    float *buf = malloc((size_t)n_out * channels * sizeof *buf);
    if (!buf)
        return -ENOMEM;
    /* Input frames at rate alpha, output at rate 1: output frame n is the
     * input at time n alpha. soxr_oneshot delivers the output aligned with the
     * input (its filter delay taken out) and flushed to the end. */
    const soxr_io_spec_t io = soxr_io_spec(SOXR_INT16_I, SOXR_FLOAT32_I);
    const soxr_quality_spec_t q = soxr_quality_spec(SOXR_HQ, SOXR_LINEAR_PHASE);
    const soxr_runtime_spec_t rt = soxr_runtime_spec(1);
    size_t done = 0;
    soxr_error_t e = soxr_oneshot(speed_ratio, 1.0, channels, in, frames, NULL, buf, n_out, &done, &io, &q, &rt);
    if (e) {
        free(buf);
        return -EIO;
    }
    uint64_t sat = 0;
    for (size_t i = 0; i < (size_t)n_out * channels; i++) {
        const float v = i < done * channels ? buf[i] * 32768.0f : 0.0f;
        long r = lrintf(v);
        if (r > 32767 || r < -32768) {
            r = r > 0 ? 32767 : -32768;
            sat++;
        }
        out[i] = (int16_t)r;
    }
    free(buf);
    if (clipped)
        *clipped += sat;
    return 0;
}
