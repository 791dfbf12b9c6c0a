/* Player and engine: trigger during playback (ADD at the next period),
 * merging of triggers within one period, unknown foci, voice stealing,
 * table hand-over on reload, and a trigger storm with bounded memory
 * (no allocation at all on the real-time path). Rewinds: the frames
 * rendered again are the same plus the new voice (checked on a simulated
 * device stream against a sum recomputed from the table), a voice that
 * ended is rendered again when a rewind reaches back into it, a slot is
 * not reused while a rewind could still need its voice. */
#include "engine.h"
#include "fw_fixture.h"

#include <errno.h>
#include <pthread.h>
#include <sched.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdio.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#ifdef HAPTIC_ASAN
#define STORM 10000u /* the storm is cheap; keep the 10^4 under ASan too */
#else
#define STORM 10000u
#endif

/* -Wl,--wrap counts every allocation made by the code under test. */
static atomic_long allocations;
void *__real_malloc(size_t n);
void *__real_calloc(size_t n, size_t m);
void *__real_realloc(void *p, size_t n);
void *__wrap_malloc(size_t n)
{
    atomic_fetch_add(&allocations, 1);
    return __real_malloc(n);
}
void *__wrap_calloc(size_t n, size_t m)
{
    atomic_fetch_add(&allocations, 1);
    return __real_calloc(n, m);
}
void *__wrap_realloc(void *p, size_t n)
{
    atomic_fetch_add(&allocations, 1);
    return __real_realloc(p, n);
}

#define C 4u
#define P 64u

static struct hd_program *program(const struct fw_table *t, struct hd_board *b)
{
    struct hd_program *p;
    char err[HD_ERR_MAX];
    fw_board(b, C, HD_FMT_S32_LE, P);
    assert_int_equal(hd_program_from_table(&t->table, b, &p, err), 0);
    return p;
}

/* The repeated set-up: a table, its program on a 4-channel board and an
 * engine playing it, made before each test from its rig_spec and freed
 * after it (cmocka fixtures). */
struct rig_spec {
    uint32_t foci, samples;
    enum fw_kind kind;
    int amp;
    uint32_t seed;
    int record_latency;
};

struct rig {
    struct fw_table t;
    struct hd_board b;
    struct hd_engine e;
};

static int rig_setup(void **state)
{
    const struct rig_spec *spec = *state;
    struct rig *r = calloc(1, sizeof *r);
    if (!r)
        return -1;
    fw_table_make(&r->t, C, spec->foci, spec->samples, spec->kind, spec->amp, spec->seed);
    struct hd_program *p = program(&r->t, &r->b);
    if (hd_engine_init(&r->e, &r->b, p, spec->record_latency) != 0)
        return -1;
    *state = r;
    return 0;
}

static int rig_teardown(void **state)
{
    struct rig *r = *state;
    hd_engine_free(&r->e);
    fw_table_free(&r->t);
    free(r);
    return 0;
}

static void push(struct hd_engine *e, uint32_t n, const uint32_t *ids)
{
    struct hd_event ev = {.t_ns = hd_now_ns(), .frame = -1, .focus_count = n};
    memcpy(ev.focus_ids, ids, n * sizeof *ids);
    assert_true(hd_spsc_push(&e->ring, &ev));
}

static void trigger_during_playback_adds_at_next_period(void **state)
{
    struct rig *r = *state;
    struct fw_table *t = &r->t;
    struct hd_engine *e = &r->e;
    int32_t out[8][P * C];
    uint32_t a = t->ids[0], bb = t->ids[1];
    push(e, 1, &a);                  /* before period 0: starts at frame 0 */
    hd_engine_period(e, out[0], P);
    hd_engine_period(e, out[1], P);
    push(e, 1, &bb);                 /* during playback: starts at frame 2P, A goes on */
    for (int q = 2; q < 8; q++)
        hd_engine_period(e, out[q], P);
    for (uint32_t f = 0; f < 8 * P; f++)
        for (uint32_t c = 0; c < C; c++) {
            int32_t want = 0;
            if (f < 300)
                want += fw_sample(t, 0, f, c);
            if (f >= 2 * P && f - 2 * P < 300)
                want += fw_sample(t, 1, f - 2 * P, c);
            assert_int_equal(out[f / P][(f % P) * C + c], want * 65536);
        }
    assert_int_equal(hd_player_active(&e->player), 0);
}

static void triggers_in_one_period_merge(void **state)
{
    struct rig *r = *state;
    struct fw_table *t = &r->t;
    struct hd_engine *e = &r->e;
    int32_t out[P * C];
    /* Two fingers and a repeat of one of them before the same boundary: one
     * voice, union {0,1}, joint gain 1/sqrt(2) (disjoint, equal energies). */
    uint32_t ids0[] = {t->ids[0]}, ids1[] = {t->ids[1], t->ids[0]}, unknown[] = {12345};
    push(e, 1, ids0);
    push(e, 2, ids1);
    push(e, 1, unknown);
    hd_engine_period(e, out, P);
    hd_engine_written(e, hd_now_ns());
    assert_int_equal(hd_player_active(&e->player), 1);
    const struct hd_voice *v = NULL;
    for (unsigned i = 0; i < HD_MAX_VOICES; i++)
        if (e->player.voices[i].program)
            v = &e->player.voices[i];
    assert_non_null(v);
    assert_int_equal(v->mix.count, 2);
    assert_true(v->mix.gain > 0.70710678118 && v->mix.gain < 0.70710678119);
    assert_int_equal(e->player.stats.unknown_foci, 1);
    assert_int_equal(atomic_load(&e->latency_count), 3); /* every event is timed */
    /* Only unknown foci: no voice at all. */
    push(e, 1, unknown);
    hd_engine_period(e, out, P);
    assert_int_equal(e->player.stats.voices_started, 1);
}

/* Four fingers before one boundary on a board that plays two: the two
 * newest play (the default), or the two first; the others are counted.
 * Their mix is the gain law's for the two alone. */
static void more_fingers_than_max_foci_follow_the_policy(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 4, 256, FW_DISJOINT, 8000, 5);
    for (int policy = 0; policy < 2; policy++) {
        struct hd_board b;
        struct hd_program *p = program(&t, &b);
        assert_int_equal(b.max_foci, 2); /* the default */
        b.foci_policy = policy ? HD_FOCI_FIRST : HD_FOCI_NEWEST;
        struct hd_engine e;
        assert_int_equal(hd_engine_init(&e, &b, p, 0), 0);
        int32_t out[P * C];
        uint32_t one[] = {t.ids[2]}, two[] = {t.ids[0], t.ids[3]}, three[] = {t.ids[1]};
        push(&e, 1, one);
        push(&e, 2, two);
        push(&e, 1, three); /* arrival order: 2, 0, 3, 1 */
        hd_engine_period(&e, out, P);
        const struct hd_voice *v = NULL;
        for (unsigned i = 0; i < HD_MAX_VOICES; i++)
            if (e.player.voices[i].program)
                v = &e.player.voices[i];
        assert_non_null(v);
        assert_int_equal(v->mix.count, 2);
        const uint32_t want0 = policy ? 2 : 3, want1 = policy ? 0 : 1; /* table indices */
        assert_int_equal(v->mix.index[0], want0);
        assert_int_equal(v->mix.index[1], want1);
        assert_int_equal(e.player.stats.policy_foci, 2);
        assert_true(v->mix.gain > 0.70710678118 && v->mix.gain < 0.70710678119); /* two disjoint foci */
        /* The samples are the two foci's, nothing of the others. */
        for (uint32_t f = 0; f < P; f++)
            for (uint32_t c = 0; c < C; c++) {
                const double want = v->mix.gain * (fw_sample(&t, want0, f, c) + fw_sample(&t, want1, f, c));
                assert_true(fabs(out[f * C + c] / 65536.0 - want) <= 1.0);
            }
        hd_engine_free(&e);
    }
    fw_table_free(&t);
}

static void oldest_voice_is_stolen(void **state)
{
    struct rig *r = *state;
    struct fw_table *t = &r->t;
    struct hd_engine *e = &r->e;
    int32_t out[P * C];
    for (unsigned i = 0; i <= HD_MAX_VOICES; i++) {
        push(e, 1, &t->ids[0]);
        hd_engine_period(e, out, P);
    }
    assert_int_equal(hd_player_active(&e->player), HD_MAX_VOICES);
    assert_int_equal(e->player.stats.voices_stolen, 1);
    /* The oldest (started first, furthest along) went: the voices started at periods 1..8. */
    uint64_t first = UINT64_MAX;
    for (unsigned i = 0; i < HD_MAX_VOICES; i++)
        first = e->player.voices[i].start < first ? e->player.voices[i].start : first;
    assert_int_equal(first, P);
    assert_int_equal(hd_engine_frame(e) - first, HD_MAX_VOICES * P);
}

static void reload_hands_over_at_a_boundary(void **state)
{
    (void)state;
    struct fw_table ta, tb;
    fw_table_make(&ta, C, 1, 200, FW_RANDOM, 1000, 21);
    fw_table_make(&tb, C, 1, 100, FW_RANDOM, 1000, 22);
    struct hd_board b;
    struct hd_program *pa = program(&ta, &b), *pb = program(&tb, &b);
    struct hd_engine e;
    assert_int_equal(hd_engine_init(&e, &b, pa, 0), 0);
    int32_t out[P * C];
    push(&e, 1, &ta.ids[0]);
    hd_engine_period(&e, out, P); /* voice from A, frames 0..63 */
    assert_int_equal(hd_engine_offer(&e, pb), 0);
    assert_int_equal(hd_engine_offer(&e, pa), -EBUSY); /* one reload at a time */
    push(&e, 1, &tb.ids[0]);
    hd_engine_period(&e, out, P); /* B is current now; A's voice continues */
    assert_ptr_equal(e.current, pb);
    for (uint32_t i = 0; i < P; i++)
        for (uint32_t c = 0; c < C; c++)
            assert_int_equal(out[i * C + c], (fw_sample(&ta, 0, P + i, c) + fw_sample(&tb, 0, i, c)) * 65536);
    assert_null(atomic_load(&e.retired)); /* A still plays */
    hd_engine_period(&e, out, P);
    hd_engine_period(&e, out, P);         /* A's voice ended (200 frames) during this period */
    hd_engine_period(&e, out, P);         /* ...and is retired at the next boundary */
    assert_ptr_equal(atomic_load(&e.retired), pa);
    hd_engine_collect(&e);
    assert_null(atomic_load(&e.retired));
    hd_engine_free(&e);
    fw_table_free(&ta);
    fw_table_free(&tb);
}

/* A device stream: frames land at their device frame; a rewind makes the
 * next write overwrite the frames it went back over, as ALSA does. */
#define DEV_FRAMES (16u * P)
struct device {
    int32_t frames[DEV_FRAMES * C];
};

static void dev_render(struct hd_engine *e, struct device *d, uint32_t frames)
{
    int32_t out[P * C];
    uint64_t at = hd_engine_frame(e);
    assert_true(at + frames <= DEV_FRAMES);
    hd_engine_period(e, out, frames);
    memcpy(d->frames + at * C, out, (size_t)frames * C * sizeof *out);
}

/* Expected: sum over voices (focus, start) of the table signal, in S32 (gain 1 each). */
static void dev_expect(const struct device *d, const struct fw_table *t, uint32_t nvoices, const uint32_t *focus,
                       const uint64_t *start, uint64_t upto)
{
    for (uint64_t f = 0; f < upto; f++)
        for (uint32_t c = 0; c < C; c++) {
            int32_t want = 0;
            for (uint32_t v = 0; v < nvoices; v++)
                if (f >= start[v] && f - start[v] < t->samples)
                    want += fw_sample(t, focus[v], (uint32_t)(f - start[v]), c);
            if (d->frames[f * C + c] != want * 65536)
                fail_msg("frame %lu channel %u: %d, expected %d", (unsigned long)f, c, d->frames[f * C + c] / 65536,
                         want);
        }
}

static void rewind_starts_a_voice_at_once(void **state)
{
    struct rig *r = *state;
    struct fw_table *t = &r->t;
    struct hd_engine *e = &r->e;
    static struct device d;
    memset(&d, 0, sizeof d);
    hd_engine_start_at(e, 2 * P, 2 * P); /* pre-fill of 2 periods; rewinds reach 2 periods back */
    assert_int_equal(hd_engine_rewindable(e), 2 * P); /* the pre-fill is silence: rendered again as such */
    /* A trigger right after the start: 24 frames of the pre-fill taken back, A at 2P - 24. */
    push(e, 1, &t->ids[0]);
    hd_engine_rewind(e, 24);
    dev_render(e, &d, 24);
    hd_engine_written(e, hd_now_ns());
    dev_render(e, &d, P);
    dev_render(e, &d, P);
    dev_render(e, &d, P); /* device frames up to 5P written */
    assert_int_equal(hd_engine_rewindable(e), 2 * P);
    /* A trigger: the device went back 40 frames; B starts at 5P - 40, and
     * those 40 frames are rendered again: A's part in them identical. */
    push(e, 1, &t->ids[1]);
    hd_engine_rewind(e, 40);
    assert_int_equal(hd_engine_frame(e), 5 * P - 40);
    dev_render(e, &d, 40);
    hd_engine_written(e, hd_now_ns());
    assert_int_equal(atomic_load(&e->latency_count), 2);
    assert_int_equal(hd_engine_frame(e), 5 * P);
    for (int q = 0; q < 6; q++)
        dev_render(e, &d, P);
    const uint32_t focus[] = {0, 1};
    const uint64_t start[] = {2 * P - 24, 5 * P - 40};
    dev_expect(&d, t, 2, focus, start, hd_engine_frame(e));
    assert_int_equal(atomic_load(&e->stats.rewinds), 2);
    assert_int_equal(atomic_load(&e->stats.rewound_frames), 24 + 40);
    /* A rewind never goes further back than the window. */
    hd_engine_rewind(e, 1000);
    assert_int_equal(hd_engine_frame(e), 11 * P - 2 * P);
    assert_int_equal(atomic_load(&e->stats.rewound_frames), 24 + 40 + 2 * P);
}

static void rewind_into_an_ended_voice(void **state)
{
    struct rig *r = *state;
    struct fw_table *t = &r->t;
    struct hd_engine *e = &r->e;
    static struct device d;
    memset(&d, 0, sizeof d);
    hd_engine_start_at(e, 0, 2 * P);
    push(e, 1, &t->ids[0]);
    dev_render(e, &d, P); /* A: frames 0..99 */
    dev_render(e, &d, P);
    dev_render(e, &d, P); /* A has ended (100 < 3P) but its tail is within reach */
    assert_int_equal(hd_player_active(&e->player), 0);
    assert_true(hd_player_uses(&e->player, e->current));
    /* Back to frame P: A's frames P..99 must come out again, B on top. */
    push(e, 1, &t->ids[1]);
    hd_engine_rewind(e, 2 * P);
    assert_int_equal(hd_engine_frame(e), P);
    dev_render(e, &d, P);
    dev_render(e, &d, P);
    for (int q = 0; q < 4; q++)
        dev_render(e, &d, P);
    const uint32_t focus[] = {0, 1};
    const uint64_t start[] = {0, P};
    dev_expect(&d, t, 2, focus, start, hd_engine_frame(e));
    /* Out of reach now: both released. */
    assert_false(hd_player_uses(&e->player, e->current));
}

static void slot_of_a_voice_in_reach_is_kept(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 1, 100, FW_RANDOM, 1000, 33);
    struct hd_board b;
    struct hd_program *p = program(&t, &b);
    struct hd_player pl;
    assert_int_equal(hd_player_init(&pl, &b), 0);
    int32_t out[P * C];
    hd_player_set_timeline(&pl, 0, 2 * P);
    uint32_t id = t.ids[0];
    assert_int_equal(hd_player_start(&pl, p, &id, 1), 1); /* V0 at 0, ends at 100 */
    hd_player_render(&pl, out, P);
    hd_player_render(&pl, out, P); /* frame 2P: V0 ended, still within reach */
    assert_int_equal(hd_player_rewindable(&pl), 2 * P);
    for (unsigned i = 1; i < HD_MAX_VOICES; i++)
        assert_int_equal(hd_player_start(&pl, p, &id, 1), 1); /* the 7 free slots */
    assert_int_equal(hd_player_rewindable(&pl), 2 * P);
    /* No free slot: V0's (ended) is taken without cutting anything, and from
     * now on no rewind may go back before this start (V0 would be missing). */
    assert_int_equal(hd_player_start(&pl, p, &id, 1), 1);
    assert_int_equal(pl.stats.voices_stolen, 0);
    assert_int_equal(hd_player_rewindable(&pl), 0);
    assert_int_equal(hd_player_rewind(&pl, 10), 0);
    /* All 8 play: the next one cuts the oldest. */
    assert_int_equal(hd_player_start(&pl, p, &id, 1), 1);
    assert_int_equal(pl.stats.voices_stolen, 1);
    assert_int_equal(hd_player_active(&pl), HD_MAX_VOICES);
    hd_player_free(&pl);
    hd_program_free(p);
    fw_table_free(&t);
}

struct storm {
    struct hd_engine *e;
    uint32_t id;
    atomic_int done;
};

static void *storm_producer(void *arg)
{
    struct storm *s = arg;
    for (uint32_t i = 0; i < STORM; i++) {
        struct hd_event ev = {.t_ns = hd_now_ns(), .frame = -1, .focus_count = 1, .focus_ids = {s->id + (i % 3) * 10}};
        hd_spsc_push(&s->e->ring, &ev); /* a full ring drops and counts */
        if (i % 64 == 0)
            sched_yield();
    }
    atomic_store(&s->done, 1);
    return NULL;
}

static void trigger_storm_bounded_memory(void **state)
{
    struct rig *r = *state;
    struct fw_table *t = &r->t;
    struct hd_engine *e = &r->e;
    int32_t out[P * C];
    struct storm s = {.e = e, .id = t->ids[2]};
    atomic_init(&s.done, 0);
    pthread_t th;
    long before = atomic_load(&allocations);
    assert_int_equal(pthread_create(&th, NULL, storm_producer, &s), 0);
    uint64_t periods = 0;
    hd_engine_start_at(e, 2 * P, 2 * P);
    while (!atomic_load(&s.done) || !hd_spsc_empty(&e->ring)) {
        hd_engine_period(e, out, P);
        hd_engine_written(e, hd_now_ns());
        periods++;
        if (periods % 2 && hd_engine_pending(e) && hd_engine_rewindable(e) > 0) { /* a trigger answered at once: rewind, render again */
            uint64_t n = hd_engine_rewindable(e) < 40 ? hd_engine_rewindable(e) : 40;
            hd_engine_rewind(e, n);
            hd_engine_period(e, out, (uint32_t)n);
            hd_engine_written(e, hd_now_ns());
            periods++;
        }
    }
    pthread_join(th, NULL);
    long during = atomic_load(&allocations) - before;
    /* pthread_create may allocate in libc (not wrapped); our code must not. */
    assert_int_equal(during, 0);
    uint64_t consumed = atomic_load(&e->latency_count), dropped = atomic_load(&e->ring.dropped);
    assert_true(consumed + dropped == STORM);
    assert_true(hd_player_active(&e->player) <= HD_MAX_VOICES);
    assert_true(e->player.stats.voices_started <= periods);
    assert_true(e->player.stats.voices_started >= 1);
}

/* The ring: peeked events stay in it until released, so a thread that sees
 * it empty knows the consumer has counted them. */
static void ring_peek_and_release(void **state)
{
    (void)state;
    static struct hd_spsc r;
    hd_spsc_init(&r);
    assert_true(hd_spsc_empty(&r));
    for (uint32_t i = 0; i < 3; i++) {
        struct hd_event ev = {.frame = -1, .focus_count = 1, .focus_ids = {i}};
        assert_true(hd_spsc_push(&r, &ev));
    }
    struct hd_event ev;
    assert_true(hd_spsc_peek(&r, 2, &ev));
    assert_int_equal(ev.focus_ids[0], 2);
    assert_false(hd_spsc_peek(&r, 3, &ev));
    hd_spsc_release(&r, 2);
    assert_false(hd_spsc_empty(&r));
    assert_true(hd_spsc_peek(&r, 0, &ev)); /* the one left is now the oldest */
    assert_int_equal(ev.focus_ids[0], 2);
    assert_false(hd_spsc_peek(&r, 1, &ev));
    hd_spsc_release(&r, 1);
    assert_true(hd_spsc_empty(&r));
    assert_false(hd_spsc_peek(&r, 0, &ev));
}

/* What the main thread's drain waits for, from the published state only:
 * busy while an event waits and while its voice has frames to render. */
static void idle_after_the_last_voice(void **state)
{
    struct rig *r = *state;
    struct fw_table *t = &r->t;
    struct hd_engine *e = &r->e;
    int32_t out[P * C];
    assert_true(hd_engine_idle(e));
    push(e, 1, &t->ids[0]);
    assert_false(hd_engine_idle(e)); /* in the ring */
    hd_engine_period(e, out, P);     /* frames 0..63 of 100 */
    assert_false(hd_engine_idle(e)); /* out of the ring, counted as a voice */
    assert_int_equal(atomic_load(&e->stats.active_voices), 1);
    hd_engine_period(e, out, P);     /* frames 64..127: the voice ends at 100 */
    assert_true(hd_engine_idle(e));
    assert_int_equal(atomic_load(&e->stats.active_voices), 0);
}

/* Each test's rig: foci, samples, kind, amplitude, seed, latency record. */
#define RIG_TEST(f) cmocka_unit_test_prestate_setup_teardown(f, rig_setup, rig_teardown, (void *)&f##_rig)
static const struct rig_spec trigger_during_playback_adds_at_next_period_rig = {2, 300, FW_RANDOM, 1000, 11, 0};
static const struct rig_spec triggers_in_one_period_merge_rig = {3, 256, FW_DISJOINT, 8000, 2, 1};
static const struct rig_spec oldest_voice_is_stolen_rig = {1, 4096, FW_RANDOM, 100, 4, 0};
static const struct rig_spec rewind_starts_a_voice_at_once_rig = {2, 300, FW_RANDOM, 1000, 31, 1};
static const struct rig_spec rewind_into_an_ended_voice_rig = {2, 100, FW_RANDOM, 1000, 32, 0};
static const struct rig_spec trigger_storm_bounded_memory_rig = {3, 2000, FW_RANDOM, 2000, 8, 1};
static const struct rig_spec idle_after_the_last_voice_rig = {1, 100, FW_RANDOM, 1000, 41, 0};

int main(void)
{
    const struct CMUnitTest tests[] = {
        RIG_TEST(trigger_during_playback_adds_at_next_period),
        RIG_TEST(triggers_in_one_period_merge),
        RIG_TEST(oldest_voice_is_stolen),
        cmocka_unit_test(more_fingers_than_max_foci_follow_the_policy),
        cmocka_unit_test(reload_hands_over_at_a_boundary),
        RIG_TEST(rewind_starts_a_voice_at_once),
        RIG_TEST(rewind_into_an_ended_voice),
        cmocka_unit_test(slot_of_a_voice_in_reach_is_kept),
        RIG_TEST(trigger_storm_bounded_memory),
        cmocka_unit_test(ring_peek_and_release),
        RIG_TEST(idle_after_the_last_voice),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
