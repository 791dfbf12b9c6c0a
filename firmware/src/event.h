/* event.h - one trigger: the foci (table ids) to play, and when it happened.
 * What every trigger source (GPIO lines and host lines, trigger.h; the
 * touchscreen, touch.h; a script, script.h) hands on, and what the ring to
 * the audio thread carries (spsc.h). A type of its own, below all of them,
 * so that none of them reaches the board through another. */
#ifndef HD_EVENT_H
#define HD_EVENT_H

#include "hd_defs.h"

#include <stdint.h>

struct hd_event {
    uint64_t t_ns; /* CLOCK_MONOTONIC when the daemon saw it (latency stats) */
    int64_t frame; /* scripted start frame, or -1 for "as soon as possible" */
    uint32_t focus_count;
    uint32_t focus_ids[HD_MAX_EVENT_FOCI];
};

#endif
