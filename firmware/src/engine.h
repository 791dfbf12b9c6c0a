/* engine.h - what the real-time audio thread does each period, and the
 * lock-free hand-offs around it:
 *   trigger thread --hd_spsc (events)--> audio thread
 *   main thread    --next (program)---> audio thread   (SIGHUP reload)
 *   audio thread   --retired (program)--> main thread  (frees it)
 * A reloaded table takes effect at a period boundary for new voices; voices
 * already playing finish from the old table, which the audio thread then
 * hands back to be freed outside the real-time path. */
#ifndef HD_ENGINE_H
#define HD_ENGINE_H

#include "player.h"
#include "spsc.h"

#include <stdatomic.h>
#include <stdint.h>

#define HD_LATENCY_CAP (1u << 17) /* trigger->ALSA latency samples kept for the report */

struct hd_engine_stats {
    _Atomic uint64_t voices_started, voices_stolen, clipped_samples, unknown_foci, dropped_foci;
    _Atomic uint64_t xruns, write_errors, periods;
};

struct hd_engine {
    struct hd_player player;
    struct hd_spsc ring;
    _Atomic(struct hd_program *) next;
    _Atomic(struct hd_program *) retired;
    struct hd_program *current, *previous;   /* audio thread only */
    uint64_t frame;                          /* device frames written so far, pre-fill included */
    /* events started in the period being written, for the latency record */
    uint32_t started_count;
    uint64_t started_t_ns[HD_RING_SIZE];
    uint32_t *latency_ns;                    /* NULL: not recorded */
    _Atomic uint32_t latency_count;
    struct hd_engine_stats stats;
};

int hd_engine_init(struct hd_engine *e, const struct hd_board *b, struct hd_program *initial, int record_latency);
/* Frees the player and the latency record, and every program still held. */
void hd_engine_free(struct hd_engine *e);

/* Audio thread: swap in a reloaded program if any, start voices for the
 * triggers that arrived, render one period into out. Real-time safe. */
void hd_engine_period(struct hd_engine *e, void *out, uint32_t frames);
/* Audio thread: the period just rendered was handed to ALSA at now_ns. */
void hd_engine_written(struct hd_engine *e, uint64_t now_ns);

/* Main thread: offer a new program. Returns 0, or -EBUSY while a previous
 * reload is still being taken over (try again later). */
int hd_engine_offer(struct hd_engine *e, struct hd_program *p);
/* Main thread: free programs the audio thread has retired. */
void hd_engine_collect(struct hd_engine *e);

uint64_t hd_now_ns(void); /* CLOCK_MONOTONIC */

#endif
