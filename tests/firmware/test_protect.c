/* The exciters' ratings (protect.h): a touch storm held at the rated power
 * on average (energy conservation of the first-order heat model), a lone
 * voice untouched, a voice stronger than the rating lowered to exactly fill
 * it, the floor below which a voice is skipped, the cooling, and the
 * refusals of bad ratings. */
#include "protect.h"

#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#define MS 1000000ull

/* 2 W, 4 ohm, tau 1 s on channel 0; channel 1 unprotected; 10 V full scale. */
static struct hd_protect make(void)
{
    struct hd_exciter_rating r[2] = {{2.0, 4.0, 1.0}, {0, 0, 0}};
    struct hd_protect pr;
    assert_int_equal(hd_protect_init(&pr, 2, r, 10.0, 48000), 0);
    return pr;
}

/* root energy (counts) whose voice at gain 1 brings `joules` into channel 0. */
static double root_for(const struct hd_protect *pr, double joules) { return sqrt(joules / pr->joules_per_count2[0]); }

static void a_storm_is_held_at_the_rated_power(void **state)
{
    (void)state;
    struct hd_protect pr = make();
    const double root[2] = {root_for(&pr, 0.5), 1e9}; /* 0.5 J a voice; channel 1 is not protected */
    double delivered = 0, late = 0;
    unsigned played = 0;
    for (uint64_t t = 1000 * MS; t < 11000 * MS; t += 10 * MS) { /* 100 touches a second for 10 s */
        double g = hd_protect_admit(&pr, t, root, 1.0, 0.0);
        assert_true(g >= 0 && g <= 1.0);
        const double j = g * g * 0.5;
        delivered += j;
        if (t >= 6000 * MS)
            late += j;
        played += g > 0;
        assert_true(hd_protect_heat_w(&pr, 0, t) <= 2.0 * (1 + 1e-12));
    }
    /* 50 W asked for; on average over the last 5 s the coil got its rated 2 W
     * (the heat sits at the rating: what it loses is what it may take). */
    assert_true(fabs(late / 5.0 - 2.0) < 0.02);
    assert_true(delivered < 2.0 * 10 + 2.0 * 1.0 + 1e-9); /* rated power x time + the initial room (2 W x tau) */
    assert_int_equal(played, 1000);                       /* every touch played, attenuated */
    assert_true(pr.attenuated >= 990);
    assert_int_equal(pr.skipped, 0);
}

static void a_lone_voice_plays_as_asked(void **state)
{
    (void)state;
    struct hd_protect pr = make();
    const double root[2] = {root_for(&pr, 0.5), 0};
    assert_true(hd_protect_admit(&pr, 5 * MS, root, 0.8, 0.0) == 0.8);
    assert_int_equal(pr.attenuated + pr.skipped, 0);
    assert_true(fabs(hd_protect_heat_w(&pr, 0, 5 * MS) - 0.64 * 0.5) < 1e-12);
    /* It cools with tau: one time constant later, 1/e of it. */
    assert_true(fabs(hd_protect_heat_w(&pr, 0, 1005 * MS) - 0.32 * exp(-1.0)) < 1e-12);
}

static void a_voice_above_the_rating_fills_it_exactly(void **state)
{
    (void)state;
    struct hd_protect pr = make();
    const double root[2] = {root_for(&pr, 8.0), 0}; /* 8 J at gain 1: four times what tau x rating allows */
    const double g = hd_protect_admit(&pr, 7 * MS, root, 1.0, 0.0);
    assert_true(fabs(g - 0.5) < 1e-12); /* 0.25 x 8 J = 2 J = 2 W x 1 s */
    assert_true(fabs(hd_protect_heat_w(&pr, 0, 7 * MS) - 2.0) < 1e-12);
    assert_int_equal(pr.attenuated, 1);
    /* Nothing left: the next one at once is skipped, whatever its floor. */
    assert_true(hd_protect_admit(&pr, 7 * MS, root, 1.0, 0.0) == 0.0);
    assert_int_equal(pr.skipped, 1);
    assert_true(fabs(hd_protect_heat_w(&pr, 0, 7 * MS) - 2.0) < 1e-12); /* a skipped voice adds nothing */
}

static void below_the_floor_is_skipped(void **state)
{
    (void)state;
    struct hd_protect pr = make();
    const double root[2] = {root_for(&pr, 8.0), 0};
    /* It could play at 0.5; the caller's floor is 0.6: skipped, no heat. */
    assert_true(hd_protect_admit(&pr, 9 * MS, root, 1.0, 0.6) == 0.0);
    assert_int_equal(pr.skipped, 1);
    assert_true(hd_protect_heat_w(&pr, 0, 9 * MS) == 0.0);
    /* At 0.5 exactly it plays. */
    assert_true(fabs(hd_protect_admit(&pr, 9 * MS, root, 1.0, 0.5 - 1e-12) - 0.5) < 1e-12);
}

static void bad_ratings_are_refused(void **state)
{
    (void)state;
    struct hd_protect pr;
    struct hd_exciter_rating good = {2, 4, 1};
    const struct hd_exciter_rating bad[] = {{-1, 4, 1}, {NAN, 4, 1}, {2, 0, 1}, {2, -4, 1}, {2, 4, 0}, {2, INFINITY, 1},
                                            {INFINITY, 4, 1}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        assert_int_equal(hd_protect_init(&pr, 1, &bad[i], 10.0, 48000), -EINVAL);
    assert_int_equal(hd_protect_init(&pr, 1, &good, 0.0, 48000), -EINVAL);
    assert_int_equal(hd_protect_init(&pr, 1, &good, 10.0, 0), -EINVAL);
    assert_int_equal(hd_protect_init(&pr, 0, &good, 10.0, 48000), -EINVAL);
    assert_int_equal(hd_protect_init(&pr, HD_MAX_CHANNELS + 1, &good, 10.0, 48000), -EINVAL);
    struct hd_exciter_rating off = {0, 0, 0}; /* unprotected: impedance and tau not needed */
    assert_int_equal(hd_protect_init(&pr, 1, &off, 10.0, 48000), 0);
    const double root[1] = {1e12};
    assert_true(hd_protect_admit(&pr, 1, root, 1.0, 0.0) == 1.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(a_storm_is_held_at_the_rated_power),
        cmocka_unit_test(a_lone_voice_plays_as_asked),
        cmocka_unit_test(a_voice_above_the_rating_fills_it_exactly),
        cmocka_unit_test(below_the_floor_is_skipped),
        cmocka_unit_test(bad_ratings_are_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
