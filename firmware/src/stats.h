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
    /* The exciters' protection, logged once per burst: when it engages, and
     * when a burst is over (HD_STATS_BURST_QUIET looks without a change). */
    uint64_t attenuated, skipped, burst_attenuated0, burst_skipped0;
    uint64_t policy_foci;
    unsigned quiet_looks;
    int in_burst;
};
#define HD_STATS_BURST_QUIET 5u /* looks of 0.2 s: a burst ends after 1 s without a protected voice */

/* Log every counter that changed since *last, then update *last. */
void hd_stats_log(struct hd_engine *e, struct hd_counters *last);

/* The latency a person feels, touch -> focal peak, for one table:
 *   input path and wake-up (measured per trigger: kernel event timestamp ->
 *   the voice's frames handed to ALSA, the latency record)
 * + the queue ahead of the voice (queue_s: the rewind margin when triggers
 *   are rewound in, else the whole buffer)
 * + the table's lead time (lead_s, NAN when the table does not say). */
struct hd_latency_chain {
    double queue_s;
    double lead_s;
    const char *queue_why;
};

/* One log line for the table at `table_path`. */
void hd_stats_log_chain(const char *table_path, const struct hd_latency_chain *c);

/* Trigger->ALSA latency percentiles, buffer latency, the chain to the focal
 * peak, memory, xruns and rewinds to path ("-": stdout). After the audio
 * thread has stopped. */
void hd_stats_latency_report(const char *path, struct hd_engine *e, double buffer_latency_s,
                             const struct hd_latency_chain *c);

#endif
