/* Player and engine: trigger during playback (ADD at the next period),
 * merging of triggers within one period, unknown foci, voice stealing,
 * table hand-over on reload, and a trigger storm with bounded memory
 * (no allocation at all on the real-time path). */
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

static void push(struct hd_engine *e, uint32_t n, const uint32_t *ids)
{
    struct hd_event ev = {.t_ns = hd_now_ns(), .frame = -1, .focus_count = n};
    memcpy(ev.focus_ids, ids, n * sizeof *ids);
    assert_true(hd_spsc_push(&e->ring, &ev));
}

static void trigger_during_playback_adds_at_next_period(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 2, 300, FW_RANDOM, 1000, 11);
    struct hd_board b;
    struct hd_program *p = program(&t, &b);
    struct hd_engine e;
    assert_int_equal(hd_engine_init(&e, &b, p, 0), 0);
    int32_t out[8][P * C];
    uint32_t a = t.ids[0], bb = t.ids[1];
    push(&e, 1, &a);                  /* before period 0: starts at frame 0 */
    hd_engine_period(&e, out[0], P);
    hd_engine_period(&e, out[1], P);
    push(&e, 1, &bb);                 /* during playback: starts at frame 2P, A goes on */
    for (int q = 2; q < 8; q++)
        hd_engine_period(&e, out[q], P);
    for (uint32_t f = 0; f < 8 * P; f++)
        for (uint32_t c = 0; c < C; c++) {
            int32_t want = 0;
            if (f < 300)
                want += fw_sample(&t, 0, f, c);
            if (f >= 2 * P && f - 2 * P < 300)
                want += fw_sample(&t, 1, f - 2 * P, c);
            assert_int_equal(out[f / P][(f % P) * C + c], want * 65536);
        }
    assert_int_equal(hd_player_active(&e.player), 0);
    hd_engine_free(&e);
    fw_table_free(&t);
}

static void triggers_in_one_period_merge(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 3, 256, FW_DISJOINT, 8000, 2);
    struct hd_board b;
    struct hd_program *p = program(&t, &b);
    struct hd_engine e;
    assert_int_equal(hd_engine_init(&e, &b, p, 1), 0);
    int32_t out[P * C];
    /* Two fingers and a repeat of one of them before the same boundary: one
     * voice, union {0,1}, joint gain 1/sqrt(2) (disjoint, equal energies). */
    uint32_t ids0[] = {t.ids[0]}, ids1[] = {t.ids[1], t.ids[0]}, unknown[] = {12345};
    push(&e, 1, ids0);
    push(&e, 2, ids1);
    push(&e, 1, unknown);
    hd_engine_period(&e, out, P);
    hd_engine_written(&e, hd_now_ns());
    assert_int_equal(hd_player_active(&e.player), 1);
    const struct hd_voice *v = NULL;
    for (unsigned i = 0; i < HD_MAX_VOICES; i++)
        if (e.player.voices[i].program)
            v = &e.player.voices[i];
    assert_non_null(v);
    assert_int_equal(v->mix.count, 2);
    assert_true(v->mix.gain > 0.70710678118 && v->mix.gain < 0.70710678119);
    assert_int_equal(e.player.stats.unknown_foci, 1);
    assert_int_equal(atomic_load(&e.latency_count), 3); /* every event is timed */
    /* Only unknown foci: no voice at all. */
    push(&e, 1, unknown);
    hd_engine_period(&e, out, P);
    assert_int_equal(e.player.stats.voices_started, 1);
    hd_engine_free(&e);
    fw_table_free(&t);
}

static void oldest_voice_is_stolen(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 1, 4096, FW_RANDOM, 100, 4);
    struct hd_board b;
    struct hd_program *p = program(&t, &b);
    struct hd_engine e;
    assert_int_equal(hd_engine_init(&e, &b, p, 0), 0);
    int32_t out[P * C];
    for (unsigned i = 0; i <= HD_MAX_VOICES; i++) {
        push(&e, 1, &t.ids[0]);
        hd_engine_period(&e, out, P);
    }
    assert_int_equal(hd_player_active(&e.player), HD_MAX_VOICES);
    assert_int_equal(e.player.stats.voices_stolen, 1);
    /* The oldest (started first, furthest along) went: the positions are now 1..8 periods. */
    uint32_t maxpos = 0;
    for (unsigned i = 0; i < HD_MAX_VOICES; i++)
        maxpos = e.player.voices[i].position > maxpos ? e.player.voices[i].position : maxpos;
    assert_int_equal(maxpos, HD_MAX_VOICES * P);
    hd_engine_free(&e);
    fw_table_free(&t);
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
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 3, 2000, FW_RANDOM, 2000, 8);
    struct hd_board b;
    struct hd_program *p = program(&t, &b);
    struct hd_engine e;
    assert_int_equal(hd_engine_init(&e, &b, p, 1), 0);
    int32_t out[P * C];
    struct storm s = {.e = &e, .id = t.ids[2]};
    atomic_init(&s.done, 0);
    pthread_t th;
    long before = atomic_load(&allocations);
    assert_int_equal(pthread_create(&th, NULL, storm_producer, &s), 0);
    uint64_t periods = 0;
    while (!atomic_load(&s.done) || atomic_load(&e.ring.tail) != atomic_load(&e.ring.head)) {
        hd_engine_period(&e, out, P);
        hd_engine_written(&e, hd_now_ns());
        periods++;
    }
    pthread_join(th, NULL);
    long during = atomic_load(&allocations) - before;
    /* pthread_create may allocate in libc (not wrapped); our code must not. */
    assert_int_equal(during, 0);
    uint64_t consumed = atomic_load(&e.latency_count), dropped = atomic_load(&e.ring.dropped);
    assert_true(consumed + dropped == STORM);
    assert_true(hd_player_active(&e.player) <= HD_MAX_VOICES);
    assert_true(e.player.stats.voices_started <= periods);
    assert_true(e.player.stats.voices_started >= 1);
    hd_engine_free(&e);
    fw_table_free(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(trigger_during_playback_adds_at_next_period),
        cmocka_unit_test(triggers_in_one_period_merge),
        cmocka_unit_test(oldest_voice_is_stolen),
        cmocka_unit_test(reload_hands_over_at_a_boundary),
        cmocka_unit_test(trigger_storm_bounded_memory),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
