/* The exciters' ratings (protect.h). A touch storm of coherent,
 * overlapping voices, rendered sample by sample: the coil's true heat (the
 * exponential average of the power, integrated here on its own) stays within
 * the rating at every sample while every touch is answered or counted; a
 * lone voice plays as asked; a voice stronger than the rating is lowered to
 * exactly fill it; the floor below which a voice is skipped; the cooling;
 * refusals of bad ratings. */
#include "protect.h"

#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <cmocka.h>

#define MS 1000000ull
#define RATE 48000u
#define Q30 ((int64_t)1 << 30)

/* 2 W, 4 ohm, tau 1 s on channel 0; channel 1 unprotected; 10 V full scale. */
static struct hd_protect make(void)
{
    struct hd_exciter_rating r[2] = {{2.0, 4.0, 1.0}, {0, 0, 0}};
    struct hd_protect pr;
    assert_int_equal(hd_protect_init(&pr, 2, r, 10.0, RATE), 0);
    return pr;
}

static uint64_t ns_of(uint64_t frame) { return frame * 1000000000ull / RATE; }

/* 100 touches a second for 10 s, each a 50 ms voice of constant amplitude
 * A (counts) on channel 0 and all of the same sign: overlapping voices add
 * coherently, the worst case for the coil. Rendered in 1 ms periods; the
 * true heat integrated per sample beside it. */
static void a_coherent_storm_stays_within_the_rating(void **state)
{
    (void)state;
    struct hd_protect pr = make();
    const uint32_t period = 48, voice = 2400;
    const double amp = 20000.0;
    const double root_one = amp * sqrt((double)voice); /* sqrt of the voice's energy at gain 1 */
    struct {
        uint64_t start;
        double g;
    } v[64];
    unsigned nv = 0, answered = 0, touches = 0;
    double heat = 0, worst = 0, energy_late = 0;
    const double j = pr.joules_per_count2[0], decay = exp(-1.0 / (RATE * 1.0));
    int64_t acc[48 * 2];
    for (uint64_t f = 0; f < 10u * RATE; f += period) {
        if (f % 480 == 0) { /* a touch every 10 ms */
            double playing[2] = {0, 0}, fresh[2] = {root_one, 1e9};
            for (unsigned i = 0; i < nv; i++)
                if (v[i].start + voice > f)
                    playing[0] += v[i].g * root_one;
            touches++;
            double g = hd_protect_admit(&pr, ns_of(f), playing, fresh, 1.0, 0.0);
            assert_true(g >= 0 && g <= 1.0);
            if (g > 0) {
                answered++;
                unsigned slot = nv; /* an ended voice's slot, else a new one */
                for (unsigned i = 0; i < nv; i++)
                    if (v[i].start + voice <= f)
                        slot = i;
                if (slot == nv) {
                    assert_true(nv < 64);
                    nv++;
                }
                v[slot].start = f;
                v[slot].g = g;
            }
        }
        for (uint32_t n = 0; n < period; n++) {
            double x = 0;
            for (unsigned i = 0; i < nv; i++)
                if (v[i].start <= f + n && f + n < v[i].start + voice)
                    x += v[i].g * amp;
            acc[2 * n] = (int64_t)llround(x * (double)Q30);
            acc[2 * n + 1] = 0;
            const double p = x * x * j * RATE; /* watts */
            heat = heat * decay + p / RATE;    /* tau = 1 s: dt / tau = 1 / RATE */
            if (heat > worst)
                worst = heat;
            if (f >= 5u * RATE)
                energy_late += p / RATE;
        }
        hd_protect_played(&pr, acc, period, 2, ns_of(f + period));
    }
    print_message("worst %.9f answered %u skipped %llu late %.4f\n", worst, answered, (unsigned long long)pr.skipped,
                  energy_late / 5);
    assert_true(worst <= 2.0); /* never above the rating, at any sample */
    assert_true(worst > 1.5);  /* and the budget used, not starved */
    assert_int_equal(touches, 1000);
    assert_int_equal(answered + pr.skipped, touches); /* every touch played or counted */
    assert_true(answered > 900);
    assert_true(energy_late / 5.0 <= 2.0 && energy_late / 5.0 > 1.0); /* average power over the last 5 s */
}

static void a_lone_voice_plays_as_asked(void **state)
{
    (void)state;
    struct hd_protect pr = make();
    const double fresh[2] = {sqrt(0.5 / pr.joules_per_count2[0]), 0}, none[2] = {0, 0}; /* 0.5 J at gain 1 */
    assert_true(hd_protect_admit(&pr, 5 * MS, none, fresh, 0.8, 0.0) == 0.8);
    assert_int_equal(pr.attenuated + pr.skipped, 0);
    /* What was played heats the coil, and it cools with tau. */
    int64_t acc[2] = {(int64_t)10000 * Q30, 0};
    hd_protect_played(&pr, acc, 1, 2, 5 * MS);
    const double h = 1e8 * pr.joules_per_count2[0] / 1.0;
    assert_true(fabs(hd_protect_heat_w(&pr, 0, 5 * MS) - h) < 1e-15);
    assert_true(fabs(hd_protect_heat_w(&pr, 0, 1005 * MS) - h * exp(-1.0)) < 1e-15);
    assert_true(hd_protect_heat_w(&pr, 1, 5 * MS) == 0.0); /* unprotected */
}

static void a_voice_above_the_rating_fills_it_exactly(void **state)
{
    (void)state;
    struct hd_protect pr = make();
    const double none[2] = {0, 0}, fresh[2] = {sqrt(8.0 / pr.joules_per_count2[0]), 0}; /* 8 J at gain 1 */
    const double g = hd_protect_admit(&pr, 7 * MS, none, fresh, 1.0, 0.0);
    assert_true(fabs(g - 0.5) < 1e-12); /* 0.25 x 8 J = 2 J = 2 W x 1 s */
    assert_int_equal(pr.attenuated, 1);
    /* That voice still playing (its bound counted): the next one is skipped. */
    const double playing[2] = {g * fresh[0], 0};
    assert_true(hd_protect_admit(&pr, 8 * MS, playing, fresh, 1.0, 0.0) == 0.0);
    assert_int_equal(pr.skipped, 1);
}

static void below_the_floor_is_skipped(void **state)
{
    (void)state;
    struct hd_protect pr = make();
    const double none[2] = {0, 0}, fresh[2] = {sqrt(8.0 / pr.joules_per_count2[0]), 0};
    /* It could play at 0.5; the caller's floor is 0.6: skipped. */
    assert_true(hd_protect_admit(&pr, 9 * MS, none, fresh, 1.0, 0.6) == 0.0);
    assert_int_equal(pr.skipped, 1);
    assert_true(fabs(hd_protect_admit(&pr, 9 * MS, none, fresh, 1.0, 0.5 - 1e-12) - 0.5) < 1e-12);
}

static void bad_ratings_are_refused(void **state)
{
    (void)state;
    struct hd_protect pr;
    struct hd_exciter_rating good = {2, 4, 1};
    const struct hd_exciter_rating bad[] = {{-1, 4, 1}, {NAN, 4, 1},      {2, 0, 1},       {2, -4, 1},
                                            {2, 4, 0},  {2, INFINITY, 1}, {INFINITY, 4, 1}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        assert_int_equal(hd_protect_init(&pr, 1, &bad[i], 10.0, RATE), -EINVAL);
    assert_int_equal(hd_protect_init(&pr, 1, &good, 0.0, RATE), -EINVAL);
    assert_int_equal(hd_protect_init(&pr, 1, &good, 10.0, 0), -EINVAL);
    assert_int_equal(hd_protect_init(&pr, 0, &good, 10.0, RATE), -EINVAL);
    assert_int_equal(hd_protect_init(&pr, HD_MAX_CHANNELS + 1, &good, 10.0, RATE), -EINVAL);
    struct hd_exciter_rating off = {0, 0, 0}; /* unprotected: impedance and tau not needed */
    assert_int_equal(hd_protect_init(&pr, 1, &off, 10.0, RATE), 0);
    const double none[1] = {0}, fresh[1] = {1e12};
    assert_true(hd_protect_admit(&pr, 1, none, fresh, 1.0, 0.0) == 1.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(a_coherent_storm_stays_within_the_rating),
        cmocka_unit_test(a_lone_voice_plays_as_asked),
        cmocka_unit_test(a_voice_above_the_rating_fills_it_exactly),
        cmocka_unit_test(below_the_floor_is_skipped),
        cmocka_unit_test(bad_ratings_are_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
