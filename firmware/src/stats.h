/* stats.h - what the main thread reports from the real-time counters: a log
 * line when a counter moved since the last look, and the latency report
 * written at exit (--latency-report). */
#ifndef HD_STATS_H
#define HD_STATS_H

#include "engine.h"

#include <stdint.h>

struct hd_counters {
    uint64_t xruns, write_errors, stolen, clipped, unknown, dropped_foci, dropped_events;
    int rewind_error;
};

/* Log every counter that changed since *last, then update *last. */
void hd_stats_log(struct hd_engine *e, struct hd_counters *last);

/* Trigger->ALSA latency percentiles, buffer latency, memory, xruns and
 * rewinds to path ("-": stdout). After the audio thread has stopped. */
void hd_stats_latency_report(const char *path, struct hd_engine *e, double buffer_latency_s);

#endif
