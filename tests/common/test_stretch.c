/* The speed compensation (haptic_stretch.h) against independent truths: a
 * stretched sine has the frequency times the ratio, a stretched pulse peaks
 * at its time over the ratio with its amplitude, and a ratio of 1 is a copy. */
#define _GNU_SOURCE
#include <haptic_stretch.h>

#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#define RATE 48000.0

static void ratio_one_is_a_copy_and_out_of_range_is_refused(void **state)
{
    (void)state;
    int16_t in[3 * 2] = {1, -2, 32767, -32768, 5, 6}, out[3 * 2] = {0};
    assert_int_equal(haptic_stretch_frames(3, 1.0), 3);
    assert_int_equal(haptic_stretch(in, 3, 2, 1.0, out, NULL), 0);
    assert_memory_equal(in, out, sizeof in);
    assert_int_equal(haptic_stretch_frames(100, 0.79), 0);
    assert_int_equal(haptic_stretch_frames(100, 1.26), 0);
    assert_int_equal(haptic_stretch(in, 3, 2, 1.3, out, NULL), -EINVAL);
    assert_int_equal(haptic_stretch(in, 3, 2, NAN, out, NULL), -EINVAL);
    assert_int_equal(haptic_stretch(in, 3, 0, 1.01, out, NULL), -EINVAL);
    assert_int_equal(haptic_stretch(in, 0, 2, 1.01, out, NULL), -EINVAL);
    /* ceil(frames / ratio): 100 / 1.25 = 80 exactly, 100 / 0.8 = 125, 101 / 1.015 = 99.5... */
    assert_int_equal(haptic_stretch_frames(100, 1.25), 80);
    assert_int_equal(haptic_stretch_frames(100, 0.8), 125);
    assert_int_equal(haptic_stretch_frames(101, 1.015), 100);
}

/* Hann-windowed DTFT magnitude of samples [a, b) of channel c at f. */
static double dtft(const int16_t *x, uint32_t channels, uint32_t c, uint32_t a, uint32_t b, double f)
{
    const uint32_t n = b - a;
    double re = 0, im = 0;
    for (uint32_t i = 0; i < n; i++) {
        const double w = (0.5 - 0.5 * cos(2 * M_PI * i / n)) * x[(size_t)(a + i) * channels + c];
        re += w * cos(2 * M_PI * f * i / RATE);
        im -= w * sin(2 * M_PI * f * i / RATE);
    }
    return hypot(re, im);
}

/* Where that magnitude is largest within 10 % of f0: 1 Hz steps, then
 * 0.02 Hz steps around the best. */
static double measured_frequency(const int16_t *x, uint32_t channels, uint32_t c, uint32_t a, uint32_t b, double f0)
{
    double fb = f0, best = -1;
    for (double f = 0.9 * f0; f <= 1.1 * f0; f += 1.0) {
        const double m = dtft(x, channels, c, a, b, f);
        if (m > best) {
            best = m;
            fb = f;
        }
    }
    const double coarse = fb;
    for (double f = coarse - 1; f <= coarse + 1; f += 0.02) {
        const double m = dtft(x, channels, c, a, b, f);
        if (m > best) {
            best = m;
            fb = f;
        }
    }
    return fb;
}

static void a_stretched_sine_has_its_frequency_times_the_ratio(void **state)
{
    (void)state;
    const uint32_t frames = 24000, C = 2;
    int16_t *in = malloc(sizeof *in * frames * C);
    assert_non_null(in);
    for (uint32_t i = 0; i < frames; i++) {
        in[i * C] = (int16_t)lrint(20000 * sin(2 * M_PI * 300.0 * i / RATE));
        in[i * C + 1] = (int16_t)lrint(-12000 * sin(2 * M_PI * 700.0 * i / RATE));
    }
    const double ratios[] = {0.97, 1.015, 1.2};
    for (size_t k = 0; k < sizeof ratios / sizeof *ratios; k++) {
        const double r = ratios[k];
        const uint32_t n = haptic_stretch_frames(frames, r);
        int16_t *out = malloc(sizeof *out * n * C);
        assert_non_null(out);
        uint64_t clipped = 0;
        assert_int_equal(haptic_stretch(in, frames, C, r, out, &clipped), 0);
        assert_int_equal(clipped, 0);
        /* Away from the ends: the frequencies scale by r, to 0.05 Hz. */
        assert_true(fabs(measured_frequency(out, C, 0, 2000, n - 2000, 300 * r) - 300 * r) < 0.06);
        assert_true(fabs(measured_frequency(out, C, 1, 2000, n - 2000, 700 * r) - 700 * r) < 0.06);
        /* And the amplitude is kept: sample n of the output is the input at n r. */
        double worst = 0;
        for (uint32_t i = 1000; i < n - 1000; i++)
            worst = fmax(worst, fabs(out[i * C] - 20000 * sin(2 * M_PI * 300.0 * i * r / RATE)));
        assert_true(worst < 3);
        free(out);
    }
    free(in);
}

static void a_stretched_pulse_peaks_at_its_time_over_the_ratio(void **state)
{
    (void)state;
    /* A two-cycle Hann burst at 300 Hz centred at 30 ms (the seed's pulse), on one channel. */
    const uint32_t frames = 4800;
    int16_t in[4800];
    const double t0 = 0.030, T = 2 / 300.0;
    for (uint32_t i = 0; i < frames; i++) {
        const double t = i / RATE - t0;
        in[i] =
            fabs(t) < T / 2 ? (int16_t)lrint(30000 * 0.5 * (1 + cos(2 * M_PI * t / T)) * cos(2 * M_PI * 300 * t)) : 0;
    }
    const double ratios[] = {0.985, 1.0, 1.015};
    for (size_t k = 0; k < 3; k++) {
        const double r = ratios[k];
        const uint32_t n = haptic_stretch_frames(frames, r);
        int16_t out[5000];
        assert_true(n <= 5000);
        assert_int_equal(haptic_stretch(in, frames, 1, r, out, NULL), 0);
        uint32_t at = 0;
        for (uint32_t i = 0; i < n; i++)
            if (abs(out[i]) > abs(out[at]))
                at = i;
        /* The peak at t0 / r (a sample either way), its height kept to 0.1 %. */
        assert_true(fabs(at - t0 / r * RATE) <= 1.0);
        assert_true(fabs(out[at] - 30000.0) < 30);
    }
}

static void full_scale_saturates_and_is_counted(void **state)
{
    (void)state;
    /* A full-scale square wave overshoots when band-limited (Gibbs): the
     * overshoot saturates and is counted. The same wave at a quarter of full
     * scale is the truth by linearity: where four times its stretch stays
     * inside the rails, the full-scale stretch equals it (to the rounding of
     * both), and it saturates exactly where four times it leaves them. */
    const uint32_t frames = 960, n = haptic_stretch_frames(960, 0.99);
    int16_t full[960], quarter[960], out[1000], ref[1000];
    for (uint32_t i = 0; i < frames; i++) {
        full[i] = (i / 48) % 2 ? -32764 : 32764;
        quarter[i] = (int16_t)(full[i] / 4);
    }
    uint64_t clipped = 0, none = 0;
    assert_int_equal(haptic_stretch(full, frames, 1, 0.99, out, &clipped), 0);
    assert_int_equal(haptic_stretch(quarter, frames, 1, 0.99, ref, &none), 0);
    assert_int_equal(none, 0);
    uint64_t beyond = 0;
    for (uint32_t i = 0; i < n; i++) {
        const long x4 = 4L * ref[i];
        if (x4 > 32767 + 4 || x4 < -32768 - 4) { /* clearly beyond a rail */
            beyond++;
            assert_true(out[i] == 32767 || out[i] == -32768);
        } else if (x4 < 32767 - 4 && x4 > -32768 + 4) {
            assert_true(labs(out[i] - x4) <= 4);
        }
    }
    assert_true(beyond > 0);
    assert_true(clipped >= beyond && clipped <= beyond + 8); /* the few within 4 counts of a rail either way */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(ratio_one_is_a_copy_and_out_of_range_is_refused),
        cmocka_unit_test(a_stretched_sine_has_its_frequency_times_the_ratio),
        cmocka_unit_test(a_stretched_pulse_peaks_at_its_time_over_the_ratio),
        cmocka_unit_test(full_scale_saturates_and_is_counted),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
