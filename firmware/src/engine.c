/* engine.c - the real-time period step and the program hand-over. */
#define _POSIX_C_SOURCE 200809L
#include "engine.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

uint64_t hd_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

int hd_engine_init(struct hd_engine *e, const struct hd_board *b, struct hd_program *initial, int record_latency)
{
    memset(e, 0, sizeof *e);
    hd_spsc_init(&e->ring);
    atomic_init(&e->next, NULL);
    atomic_init(&e->retired, NULL);
    atomic_init(&e->latency_count, 0);
    e->current = initial;
    int rc = hd_player_init(&e->player, b);
    if (rc)
        return rc;
    if (record_latency) {
        e->latency_ns = calloc(HD_LATENCY_CAP, sizeof *e->latency_ns);
        if (!e->latency_ns) {
            hd_player_free(&e->player);
            return -ENOMEM;
        }
    }
    return 0;
}

void hd_engine_free(struct hd_engine *e)
{
    hd_player_free(&e->player);
    free(e->latency_ns);
    e->latency_ns = NULL;
    hd_program_free(atomic_exchange(&e->next, NULL));
    hd_program_free(atomic_exchange(&e->retired, NULL));
    hd_program_free(e->previous);
    hd_program_free(e->current);
    e->previous = e->current = NULL;
}

int hd_engine_offer(struct hd_engine *e, struct hd_program *p)
{
    struct hd_program *expected = NULL;
    if (!atomic_compare_exchange_strong(&e->next, &expected, p))
        return -EBUSY;
    return 0;
}

void hd_engine_collect(struct hd_engine *e) { hd_program_free(atomic_exchange(&e->retired, NULL)); }

static void swap_programs(struct hd_engine *e)
{
    if (!e->previous) {
        struct hd_program *n = atomic_exchange_explicit(&e->next, NULL, memory_order_acq_rel);
        if (n) {
            e->previous = e->current;
            e->current = n;
        }
    }
    if (e->previous && !hd_player_uses(&e->player, e->previous)) {
        struct hd_program *expected = NULL;
        if (atomic_compare_exchange_strong_explicit(&e->retired, &expected, e->previous, memory_order_acq_rel,
                                                    memory_order_relaxed))
            e->previous = NULL;
    }
}

static void publish(struct hd_engine *e)
{
    const struct hd_player_stats *s = &e->player.stats;
    atomic_store_explicit(&e->stats.voices_started, s->voices_started, memory_order_relaxed);
    atomic_store_explicit(&e->stats.voices_stolen, s->voices_stolen, memory_order_relaxed);
    atomic_store_explicit(&e->stats.clipped_samples, s->clipped_samples, memory_order_relaxed);
    atomic_store_explicit(&e->stats.unknown_foci, s->unknown_foci, memory_order_relaxed);
    atomic_store_explicit(&e->stats.dropped_foci, s->dropped_foci, memory_order_relaxed);
    atomic_store_explicit(&e->stats.voices_attenuated, e->player.protect.attenuated, memory_order_relaxed);
    atomic_store_explicit(&e->stats.policy_foci, s->policy_foci, memory_order_relaxed);
    atomic_store_explicit(&e->stats.voices_skipped, e->player.protect.skipped, memory_order_relaxed);
    atomic_fetch_add_explicit(&e->stats.periods, 1, memory_order_relaxed);
    atomic_store_explicit(&e->stats.active_voices, hd_player_active(&e->player), memory_order_relaxed);
}

void hd_engine_period(struct hd_engine *e, void *out, uint32_t frames)
{
    swap_programs(e);
    /* Merge every trigger that arrived since the last boundary into one voice. */
    uint32_t ids[2 * HD_MAX_VOICE_FOCI];
    uint32_t n_ids = 0;
    struct hd_event ev;
    e->started_count = 0;
    /* At most one ring's worth per period: a producer pushing as fast as we
     * take must not keep the real-time thread in this loop. */
    while (e->started_count < HD_RING_SIZE && hd_spsc_peek(&e->ring, e->started_count, &ev)) {
        e->started_t_ns[e->started_count++] = ev.t_ns;
        for (uint32_t i = 0; i < ev.focus_count; i++) {
            uint32_t k;
            for (k = 0; k < n_ids; k++)
                if (ids[k] == ev.focus_ids[i])
                    break;
            if (k < n_ids)
                continue;
            if (n_ids == sizeof ids / sizeof ids[0]) {
                e->player.stats.dropped_foci++;
                continue;
            }
            ids[n_ids++] = ev.focus_ids[i];
        }
    }
    if (n_ids && e->current)
        hd_player_start(&e->player, e->current, ids, n_ids);
    hd_player_render(&e->player, out, frames);
    publish(e);
    /* Only now do the events leave the ring: after the voice count that
     * includes them (hd_engine_idle). */
    if (e->started_count)
        hd_spsc_release(&e->ring, e->started_count);
}

void hd_engine_start_at(struct hd_engine *e, uint64_t frame, uint32_t rewind_window)
{
    hd_player_set_timeline(&e->player, frame, rewind_window);
}

uint64_t hd_engine_frame(const struct hd_engine *e) { return e->player.frame; }

uint64_t hd_engine_rewindable(const struct hd_engine *e) { return hd_player_rewindable(&e->player); }

void hd_engine_rewind(struct hd_engine *e, uint64_t frames)
{
    uint64_t n = hd_player_rewind(&e->player, frames);
    atomic_fetch_add_explicit(&e->stats.rewinds, 1, memory_order_relaxed);
    atomic_fetch_add_explicit(&e->stats.rewound_frames, n, memory_order_relaxed);
}

int hd_engine_pending(struct hd_engine *e) { return !hd_spsc_empty(&e->ring); }

bool hd_engine_idle(struct hd_engine *e)
{
    /* Ring first: its acquire load of head makes the count published before
     * the release of the last event visible (spsc.h). */
    if (!hd_spsc_empty(&e->ring))
        return false;
    return atomic_load_explicit(&e->stats.active_voices, memory_order_relaxed) == 0;
}

void hd_engine_written(struct hd_engine *e, uint64_t now_ns)
{
    if (!e->latency_ns)
        return;
    uint32_t n = atomic_load_explicit(&e->latency_count, memory_order_relaxed);
    for (uint32_t i = 0; i < e->started_count && n < HD_LATENCY_CAP; i++) {
        uint64_t d = now_ns > e->started_t_ns[i] ? now_ns - e->started_t_ns[i] : 0;
        e->latency_ns[n++] = d > UINT32_MAX ? UINT32_MAX : (uint32_t)d;
    }
    e->started_count = 0;
    atomic_store_explicit(&e->latency_count, n, memory_order_release);
}
