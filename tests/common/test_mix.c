/* The mixing law (haptic_mix.h) against hand-computed vectors: the peak
 * envelope of a signal, the bound of a sum, each of the three gains binding
 * in turn, and the rounding of the device formats. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#include <haptic_mix.h>

#include <math.h>
#include <stdint.h>

static double gram2(const void *ctx, uint32_t i, uint32_t j) { return ((const double *)ctx)[i * 2 + j]; }

static void envelope_and_bound(void **state)
{
    (void)state;
    /* 130 frames x 2 channels: blocks [0,64) [64,128) [128,130). */
    static int16_t s[130 * 2];
    s[10 * 2 + 0] = -32768; /* block 0, channel 0 */
    s[63 * 2 + 1] = 5;      /* block 0, channel 1, its last frame */
    s[64 * 2 + 1] = -7;     /* block 1, channel 1, its first frame */
    s[129 * 2 + 0] = 300;   /* block 2 (partial), channel 0, the last frame */
    assert_int_equal(haptic_mix_blocks(130), 3);
    assert_int_equal(haptic_mix_blocks(128), 2);
    assert_int_equal(haptic_mix_blocks(1), 1);
    uint16_t e[3 * 2];
    haptic_mix_block_peaks(s, 130, 2, e);
    const uint16_t want[] = {32768, 5, 0, 7, 300, 0};
    for (int i = 0; i < 6; i++)
        assert_int_equal(e[i], want[i]);
    const uint16_t other[] = {1, 100, 2, 3, 40000, 0};
    const uint16_t *both[] = {e, other};
    /* Per block and channel: 32769, 105, 2, 10, 40300, 0. */
    assert_int_equal(haptic_mix_peak_bound(both, 2, 3, 2), 40300);
    assert_int_equal(haptic_mix_peak_bound(both, 1, 3, 2), 32768);
}

static void each_gain_binds_in_turn(void **state)
{
    (void)state;
    haptic_mix_gain g;
    /* Two uncorrelated foci of energy 4: g_energy = sqrt(4 / 8). */
    const double uncorrelated[] = {4, 0, 0, 4};
    haptic_mix_gain_of(gram2, uncorrelated, 2, 100, 1.0, 1.0, &g);
    assert_true(fabs(g.energy - sqrt(0.5)) < 1e-15);
    assert_true(fabs(g.peak - 327.67) < 1e-12);
    assert_true(g.gain == g.energy);
    assert_int_equal(g.gain_q30, llround(sqrt(0.5) * 1073741824.0));
    /* Anti-correlated: the sum is small, g_energy large; the limit binds. */
    const double anti[] = {4, -3.5, -3.5, 4};
    haptic_mix_gain_of(gram2, anti, 2, 100, 1.0, 1.5, &g);
    assert_true(fabs(g.energy - 2.0) < 1e-15); /* sqrt(4 / 1) */
    assert_true(g.gain == 1.5);
    /* A large peak bound: the peak gain binds. */
    haptic_mix_gain_of(gram2, uncorrelated, 2, 65534, 1.0, 1.0, &g);
    assert_true(g.gain == 0.5 * 32767.0 / 32767.0);
    /* One focus plays as stored; signals that cancel exactly are silent. */
    const double one[] = {9, 0, 0, 0};
    haptic_mix_gain_of(gram2, one, 1, 30000, 1.0, 1.0, &g);
    assert_true(g.gain == 1.0);
    const double cancel[] = {4, -4, -4, 4};
    haptic_mix_gain_of(gram2, cancel, 2, 0, 1.0, 1.0, &g);
    assert_true(g.energy == 0.0 && g.gain == 0.0 && g.gain_q30 == 0);
    /* The user's level scales the energy gain; the peak and the limit still bind. */
    haptic_mix_gain_of(gram2, uncorrelated, 2, 100, 0.5, 1.0, &g);
    assert_true(fabs(g.gain - 0.5 * sqrt(0.5)) < 1e-15);
    haptic_mix_gain_of(gram2, uncorrelated, 2, 65534, 2.0, 4.0, &g);
    assert_true(g.gain == 0.5); /* 2 x 0.707 = 1.41 > the peak's 0.5 */
    haptic_mix_gain_of(gram2, uncorrelated, 2, 100, 2.0, 1.2, &g);
    assert_true(g.gain == 1.2); /* the limit */
}

static void device_formats_round_half_up_and_saturate(void **state)
{
    (void)state;
    const int64_t one = (int64_t)1 << 30, half = one / 2;
    const int64_t acc[] = {0, half, half - 1, -half, -half - 1, 32767 * one, 32768 * one, -32768 * one, -32769 * one};
    int16_t s16[9];
    assert_int_equal(haptic_mix_to_s16(acc, s16, 9), 2);
    const int16_t want16[] = {0, 1, 0, 0, -1, 32767, 32767, -32768, -32768};
    for (int i = 0; i < 9; i++)
        assert_int_equal(s16[i], want16[i]);
    int32_t s32[4];
    const int64_t acc32[] = {one, -one, (int64_t)1 << 13, 40000 * one};
    assert_int_equal(haptic_mix_to_s32(acc32, s32, 4), 1);
    assert_int_equal(s32[0], 65536);
    assert_int_equal(s32[1], -65536);
    assert_int_equal(s32[2], 1); /* half of one S32 step rounds up */
    assert_int_equal(s32[3], INT32_MAX);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(envelope_and_bound),
        cmocka_unit_test(each_gain_binds_in_turn),
        cmocka_unit_test(device_formats_round_half_up_and_saturate),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
