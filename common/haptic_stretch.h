/* haptic_stretch.h - a table played on a panel whose bending waves are
 * faster or slower than those of the plate it was calibrated for.
 *
 * In the thin (Kirchhoff) plate, Young's modulus E, the density rho and the
 * thickness d reach the response from force to displacement only through
 * kappa = sqrt(D / (rho d)), D = E d^3 / (12 (1 - nu^2)), which sets the time
 * scale, and through the mass per area rho d, a gain. A panel whose kappa is
 * alpha times the calibrated plate's therefore has the response
 * H'(t) = g H(alpha t): every resonance alpha times higher, every path
 * travelled alpha times sooner. A drive played alpha times faster,
 * s'(t) = s(alpha t), gives on it exactly the calibrated field, alpha times
 * sooner and scaled by g / alpha: the same focus, the same contrast, the same
 * quiet elsewhere (docs/robustness.md, "Speed compensation").
 *
 * alpha, the speed ratio, is what a resonance of the panel measured against
 * the same resonance of the calibrated plate gives (E, rho and d of a batch
 * at once); a temperature change moves it by sqrt(1 + (dE/E/dT) dT). It is
 * not the ratio of bending-wave speeds at one frequency: that is sqrt(alpha).
 *
 * The drive is resampled with soxr (linear phase, 20-bit quality), so its
 * frame n of the output is the input at time n * alpha; the result is rounded
 * to int16 with saturation. Speed ratio 1 is a copy, bit for bit. */
#ifndef HAPTIC_STRETCH_H
#define HAPTIC_STRETCH_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The speed ratios a stretch takes: a panel whose response runs up to 1.25
 * times faster or slower than the calibrated plate's (d off by 20-25 %, E by
 * 36-56 %, acrylic 90 K off its calibration temperature: far beyond any
 * panel a table is meant for). */
#define HAPTIC_STRETCH_MIN_RATIO 0.8
#define HAPTIC_STRETCH_MAX_RATIO 1.25

/* Frames of a stretched signal of `frames` input frames: ceil(frames / ratio),
 * 0 for a ratio out of range. */
uint32_t haptic_stretch_frames(uint32_t frames, double speed_ratio);

/* Resample `frames` interleaved frames of `channels` int16 samples into `out`
 * (haptic_stretch_frames(frames, speed_ratio) frames, interleaved). Adds the
 * samples that saturated to *clipped when given. Returns 0, -EINVAL for an
 * argument out of range, -ENOMEM, or -EIO when the resampler fails. */
int haptic_stretch(const int16_t *in, uint32_t frames, uint32_t channels, double speed_ratio, int16_t *out,
                   uint64_t *clipped);

#ifdef __cplusplus
}
#endif
#endif /* HAPTIC_STRETCH_H */
