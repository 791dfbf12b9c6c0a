/* Player and engine: trigger during playback (ADD at the next period),
 * merging of triggers within one period, unknown foci, voice stealing,
 * table hand-over on reload, and a trigger storm with bounded memory
 * (no allocation at all on the real-time path). A table's safe ranges
 * (format 1.3): a voice's gain clamped into its foci's, and the exciters'
 * protection skipping a voice it would lower below its range. Rewinds: the frames
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
    push(e, 1, &a); /* before period 0: starts at frame 0 */
    hd_engine_period(e, out[0], P);
    hd_engine_period(e, out[1], P);
    push(e, 1, &bb); /* during playback: starts at frame 2P, A goes on */
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
    hd_engine_period(&e, out, P); /* A's voice ended (200 frames) during this period */
    hd_engine_period(&e, out, P); /* ...and is retired at the next boundary */
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
    hd_engine_start_at(e, 2 * P, 2 * P);              /* pre-fill of 2 periods; rewinds reach 2 periods back */
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
        if (periods % 2 && hd_engine_pending(e) &&
            hd_engine_rewindable(e) > 0) { /* a trigger answered at once: rewind, render again */
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
    hd_engine_period(e, out, P); /* frames 64..127: the voice ends at 100 */
    assert_true(hd_engine_idle(e));
    assert_int_equal(atomic_load(&e->stats.active_voices), 0);
}

/* The table's safe ranges (format 1.3) re-encoded into t: threshold 1 um,
 * whole area, focus f's range r[f]; NULL: the section left out. */
static void set_ranges(struct fw_table *t, haptic_range_spec *spec, const haptic_gain_range *r)
{
    spec->threshold_m = 1e-6;
    spec->scope = HAPTIC_RANGE_WHOLE_AREA;
    spec->focus = r;
    t->range = r ? spec : NULL;
    fw_table_encode(t, NULL);
}

/* The voice's gain is clamped into the intersection of its foci's safe
 * ranges, without an allocation; the gains by hand. Four disjoint foci of
 * equal energy (two together: energy gain 1/sqrt(2)), amplitude 4000 (peak
 * limit 8.19), [mixer] gain_limit 4. */
static void a_voice_plays_within_its_foci_safe_range(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 4, 256, FW_DISJOINT, 4000, 9);
    const haptic_gain_range r[4] = {{0.5, 2.0}, {1.25, 3.0}, {0.1, 0.8}, {0.1, INFINITY}};
    haptic_range_spec spec;
    set_ranges(&t, &spec, r);
    const double top2 = 2.0 * (1 - 1e-6), top08 = 0.8 * (1 - 1e-6), s2 = sqrt(0.5);
    struct {
        uint32_t n, f[2];
        double level, want, hi;
    } cases[] = {
        {1, {0, 0}, 1.0, 1.0, 2.0},  /* inside */
        {1, {0, 0}, 0.01, 0.5, 2.0}, /* below: its bottom */
        {1, {0, 0}, 3.5, top2, 2.0}, /* above: its top */
        {1, {1, 0}, 1.0, 1.25, 3.0},     {1, {2, 0}, 1.0, top08, 0.8},
        {1, {3, 0}, 3.5, 3.5, INFINITY}, /* unbounded above */
        {1, {3, 0}, 6.0, 4.0, INFINITY}, /* gain_limit binds, not the range */
        {2, {0, 1}, 1.0, 1.25, 2.0},     /* [1.25, 2): 1/sqrt(2) raised to 1.25 */
        {2, {0, 2}, 1.0, s2, 0.8},       /* [0.5, 0.8): 1/sqrt(2) inside */
        {2, {0, 2}, 2.0, top08, 0.8},    /* sqrt(2) lowered to the top */
        {2, {1, 2}, 1.0, top08, 0.8},    /* [1.25, 0.8) holds no gain: the top, safety first */
    };
    for (int with = 1; with >= 0; with--) {
        if (!with)
            set_ranges(&t, &spec, NULL); /* the same table without the section: the law alone */
        struct hd_board b;
        struct hd_program *p = program(&t, &b);
        b.gain_limit = 4.0;
        for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
            struct hd_player pl;
            assert_int_equal(hd_player_init(&pl, &b), 0);
            hd_player_set_level(&pl, cases[i].level);
            const uint32_t ids[2] = {t.ids[cases[i].f[0]], t.ids[cases[i].f[1]]};
            const long before = atomic_load(&allocations);
            assert_int_equal(hd_player_start(&pl, p, ids, cases[i].n), 1);
            assert_int_equal(atomic_load(&allocations), before); /* real-time path */
            const struct hd_mix *m = &pl.voices[0].mix;
            double want = cases[i].want;
            if (!with) {
                const double law = cases[i].level * (cases[i].n == 2 ? s2 : 1.0);
                want = law < 4.0 ? law : 4.0;
            }
            if (fabs(m->gain - want) > 1e-12 * want)
                fail_msg("%s case %zu: gain %.17g, want %.17g", with ? "ranged" : "plain", i, m->gain, want);
            if (with && !(m->gain < cases[i].hi && (double)m->gain_q30 / (1 << 30) < cases[i].hi))
                fail_msg("case %zu: gain %.17g (Q30 %lld) reaches hi %g", i, m->gain, (long long)m->gain_q30,
                         cases[i].hi);
            if (with && i == 3) { /* focus 1 at its bottom, 1.25: the rendered samples (its slot, frames 64..127) */
                int32_t out[2 * P * C];
                hd_player_render(&pl, out, P);
                hd_player_render(&pl, out + P * C, P);
                for (uint32_t n = P; n < 2 * P; n++)
                    for (uint32_t c = 0; c < C; c++)
                        assert_true(fabs(out[n * C + c] - 1.25 * 65536.0 * fw_sample(&t, 1, n, c)) <= 1.0);
            }
            hd_player_free(&pl);
        }
        hd_program_free(p);
    }
    fw_table_free(&t);
}

/* The exciters' protection may lower a voice, but not below the bottom of
 * its safe range (where the focus is not felt): then it is skipped, and
 * counted. One focus of constant amplitude 3000 on 4 channels x 256 frames;
 * the rating is set so the coils take it at gain 0.6 at most:
 * P tau = 0.36 J E (J joules per count^2, E = 256 x 3000^2 per channel). */
static void protection_skips_a_voice_it_would_lower_below_its_range(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 1, 256, FW_CONSTANT, 3000, 1);
    const double J = (10.0 / 32767.0) * (10.0 / 32767.0) / 4.0 / 48000.0, E = 256.0 * 3000.0 * 3000.0;
    const struct {
        int ranged;
        double lo;
        double want;
    } cases[] = {
        {0, 0, 0.6},                    /* no range section: lowered to 0.6, as before */
        {1, 0.5, 0.6},                  /* bottom 0.5: lowered to 0.6, still inside */
        {1, 0.59, 0.6}, {1, 0.61, 0.0}, /* bottom 0.61: 0.6 would not be felt: skipped */
        {1, 0.9, 0.0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        const haptic_gain_range r = {cases[i].lo, 2.0};
        haptic_range_spec spec;
        set_ranges(&t, &spec, cases[i].ranged ? &r : NULL);
        struct hd_board b;
        struct hd_program *p = program(&t, &b);
        b.exciters.enabled = true;
        b.exciters.power_count = b.exciters.impedance_count = b.exciters.tau_count = 1;
        b.exciters.rated_power_w[0] = 0.36 * J * E / 1.0;
        b.exciters.impedance_ohm[0] = 4.0;
        b.exciters.tau_s[0] = 1.0;
        b.amp_full_scale_v = 10.0;
        struct hd_player pl;
        assert_int_equal(hd_player_init(&pl, &b), 0);
        assert_true(pl.protected);
        const int started = hd_player_start(&pl, p, &t.ids[0], 1);
        assert_int_equal(started, cases[i].want > 0);
        assert_int_equal(pl.protect.skipped, cases[i].want > 0 ? 0 : 1);
        assert_int_equal(pl.protect.attenuated, cases[i].want > 0 ? 1 : 0);
        if (started && fabs(pl.voices[0].mix.gain - cases[i].want) > 1e-9)
            fail_msg("case %zu: gain %.12g, want %g", i, pl.voices[0].mix.gain, cases[i].want);
        hd_player_free(&pl);
        hd_program_free(p);
    }
    fw_table_free(&t);
}

/* The main thread's one line on what the clamp does to the foci alone at a
 * level (hd_program_range_note), by hand: 20 log10(1.25) = +1.94 dB,
 * 20 log10(0.8 (1 - 1e-6)) = -1.94 dB, 20 log10(2 (1 - 1e-6)) = +6.02 dB. */
static void the_clamp_is_said_in_one_line(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 4, 256, FW_DISJOINT, 4000, 9);
    haptic_gain_range r[4] = {{0.5, 2.0}, {1.25, 3.0}, {0.1, 0.8}, {0.1, INFINITY}};
    haptic_range_spec spec;
    set_ranges(&t, &spec, r);
    struct hd_board b;
    struct hd_program *p = program(&t, &b);
    char line[HD_ERR_MAX];
    const struct {
        double level;
        int n;
        const char *want;
    } cases[] = {
        {1.0, 2,
         "intensity +0.0 dB: above the safe range of 1 of 4 foci (tops -1.9..-1.9 dB): they play at their "
         "tops; below the safe range of 1 of 4 foci (bottoms +1.9..+1.9 dB): they play at their bottoms"},
        {pow(10, 8 / 20.0), 2,
         "intensity +8.0 dB: above the safe range of 2 of 4 foci (tops -1.9..+6.0 dB): they "
         "play at their tops"},
        {0.5, 1,
         "intensity -6.0 dB: below the safe range of 1 of 4 foci (bottoms +1.9..+1.9 dB): they play at "
         "their bottoms"},
        {0.01, 4,
         "intensity -40.0 dB: below the safe range of 4 of 4 foci (bottoms -20.0..+1.9 dB): they play at "
         "their bottoms"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        assert_int_equal(hd_program_range_note(p, cases[i].level, line, sizeof line), cases[i].n);
        assert_string_equal(line, cases[i].want);
    }
    hd_program_free(p);
    /* Every focus inside: nothing to say. A focus that passes at no gain is said at any level. */
    r[1].lo = 0.5;
    r[2].hi = 2.0;
    set_ranges(&t, &spec, r);
    p = program(&t, &b);
    assert_int_equal(hd_program_range_note(p, 1.0, line, sizeof line), 0);
    assert_string_equal(line, "");
    hd_program_free(p);
    r[2].lo = 3.0;
    set_ranges(&t, &spec, r);
    p = program(&t, &b);
    assert_int_equal(hd_program_range_note(p, 1.0, line, sizeof line), 1);
    assert_string_equal(line, "intensity +0.0 dB: 1 of 4 foci pass at no gain (tops +6.0..+6.0 dB): they play at "
                              "their tops");
    hd_program_free(p);
    /* No range section: nothing. */
    set_ranges(&t, &spec, NULL);
    p = program(&t, &b);
    assert_null(p->range);
    assert_int_equal(hd_program_range_note(p, 4.0, line, sizeof line), 0);
    assert_string_equal(line, "");
    hd_program_free(p);
    fw_table_free(&t);
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
        cmocka_unit_test(a_voice_plays_within_its_foci_safe_range),
        cmocka_unit_test(protection_skips_a_voice_it_would_lower_below_its_range),
        cmocka_unit_test(the_clamp_is_said_in_one_line),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
