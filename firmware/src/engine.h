/* engine.h - what the real-time audio thread does each period, and the
 * lock-free hand-offs around it:
 *   trigger thread --hd_spsc (events)--> audio thread
 *   main thread    --next (program)---> audio thread   (SIGHUP reload)
 *   audio thread   --retired (program)--> main thread  (frees it)
 * A reloaded table takes effect at a period boundary for new voices; voices
 * already playing finish from the old table, which the audio thread then
 * hands back to be freed outside the real-time path.
 *
 * A trigger is started either at the next period (hd_engine_period drains the
 * ring before it renders) or at once: the audio thread rewinds the device's
 * queued frames, hd_engine_rewind moves the render position back by as many,
 * and hd_engine_period renders them again with the new voice in them. */
#ifndef HD_ENGINE_H
#define HD_ENGINE_H

#include "player.h"
#include "spsc.h"

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#define HD_LATENCY_CAP (1u << 17) /* trigger->ALSA latency samples kept for the report */

struct hd_engine_stats {
    _Atomic uint64_t voices_started, voices_stolen, clipped_samples, unknown_foci, dropped_foci;
    _Atomic uint64_t voices_attenuated, voices_skipped; /* by the exciters' ratings (protect.h) */
    _Atomic uint64_t policy_foci;                       /* left out by [mixer] max_foci */
    _Atomic uint64_t xruns, write_errors, periods;
    _Atomic uint64_t rewinds, rewound_frames; /* triggers started at once, and the frames rendered again */
    _Atomic int rewind_error;                 /* the ALSA error that disabled rewinding, 0 if none */
    _Atomic uint32_t active_voices;           /* voices with frames still to render, after the last render */
};

struct hd_engine {
    struct hd_player player;
    struct hd_spsc ring;
    _Atomic(struct hd_program *) next;
    _Atomic(struct hd_program *) retired;
    struct hd_program *current, *previous; /* audio thread only */
    /* events started in the period being written, for the latency record */
    uint32_t started_count;
    uint64_t started_t_ns[HD_RING_SIZE];
    uint32_t *latency_ns; /* NULL: not recorded */
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

/* Before the first period: the device has `frame` frames already (the
 * pre-fill), and rewinds may later go back up to `rewind_window` frames
 * (0 in scripted mode: no rewinds). */
void hd_engine_start_at(struct hd_engine *e, uint64_t frame, uint32_t rewind_window);
/* Device frame the next render starts at (frames handed to ALSA so far). */
uint64_t hd_engine_frame(const struct hd_engine *e);
/* Audio thread: frames the engine can render again (the most a rewind may go back). */
uint64_t hd_engine_rewindable(const struct hd_engine *e);
/* Audio thread: the device went back `frames` frames (<= hd_engine_rewindable):
 * the next renders produce them again, with the voices started since. */
void hd_engine_rewind(struct hd_engine *e, uint64_t frames);
/* Audio thread: whether a trigger waits in the ring. */
int hd_engine_pending(struct hd_engine *e);
/* Any thread, once the trigger producer has stopped: whether nothing is left
 * to play (no event waits, no voice has frames to render). Reads only what
 * the audio thread publishes (never the player, whose 64-bit frame counter
 * could tear on a 32-bit CPU). Events leave the ring only after the active
 * voice count that includes them is published, so an event between the ring
 * and a voice is never missed. */
bool hd_engine_idle(struct hd_engine *e);

/* Main thread: offer a new program. Returns 0, or -EBUSY while a previous
 * reload is still being taken over (try again later). */
int hd_engine_offer(struct hd_engine *e, struct hd_program *p);
/* Main thread: free programs the audio thread has retired. */
void hd_engine_collect(struct hd_engine *e);

uint64_t hd_now_ns(void); /* CLOCK_MONOTONIC */

#endif
