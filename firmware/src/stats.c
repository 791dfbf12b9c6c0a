/* stats.c - counter logging and the latency report (main thread only). */
#define _POSIX_C_SOURCE 200809L
#include "stats.h"

#include "log.h"

#include <alsa/asoundlib.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void hd_stats_log(struct hd_engine *e, struct hd_counters *last)
{
    struct hd_engine_stats *s = &e->stats;
    struct hd_counters now = {
        .xruns = atomic_load(&s->xruns),
        .write_errors = atomic_load(&s->write_errors),
        .stolen = atomic_load(&s->voices_stolen),
        .clipped = atomic_load(&s->clipped_samples),
        .unknown = atomic_load(&s->unknown_foci),
        .dropped_foci = atomic_load(&s->dropped_foci),
        .dropped_events = atomic_load(&e->ring.dropped),
        .rewind_error = atomic_load(&s->rewind_error),
    };
    now.policy_foci = atomic_load(&s->policy_foci);
    if (now.policy_foci != last->policy_foci)
        hd_log(LOG_INFO, "more fingers than [mixer] max_foci: %llu foci left out in total (the %s played)",
               (unsigned long long)now.policy_foci, e->player.foci_policy == HD_FOCI_NEWEST ? "newest" : "first");
    now.attenuated = atomic_load(&s->voices_attenuated);
    now.skipped = atomic_load(&s->voices_skipped);
    now.in_burst = last->in_burst;
    now.burst_attenuated0 = last->burst_attenuated0;
    now.burst_skipped0 = last->burst_skipped0;
    now.quiet_looks = last->quiet_looks;
    if (now.attenuated != last->attenuated || now.skipped != last->skipped) {
        if (!now.in_burst) {
            hd_log(LOG_WARNING, "exciter protection engaged: voices lowered or skipped to keep the exciters within "
                                "their ratings ([exciters] in the board file)");
            now.in_burst = 1;
            now.burst_attenuated0 = last->attenuated;
            now.burst_skipped0 = last->skipped;
        }
        now.quiet_looks = 0;
    } else if (now.in_burst && ++now.quiet_looks >= HD_STATS_BURST_QUIET) {
        hd_log(LOG_WARNING,
               "exciter protection: burst over, %llu voices lowered and %llu skipped in it (%llu and "
               "%llu in total)",
               (unsigned long long)(now.attenuated - now.burst_attenuated0),
               (unsigned long long)(now.skipped - now.burst_skipped0), (unsigned long long)now.attenuated,
               (unsigned long long)now.skipped);
        now.in_burst = 0;
    }
    if (now.rewind_error && !last->rewind_error) /* once: rewinding stays off */
        hd_log(LOG_WARNING, "ALSA rewind failed (%s): triggers now start at the next period boundary",
               snd_strerror(now.rewind_error));
    if (now.xruns != last->xruns)
        hd_log(LOG_WARNING, "xrun recovered (%llu in total)", (unsigned long long)now.xruns);
    if (now.write_errors != last->write_errors)
        hd_log(LOG_ERR, "ALSA write failed (%llu in total)", (unsigned long long)now.write_errors);
    if (now.stolen != last->stolen)
        hd_log(LOG_WARNING, "voices stolen: %llu in total", (unsigned long long)now.stolen);
    if (now.clipped != last->clipped)
        hd_log(LOG_WARNING, "overlapping voices saturated %llu samples in total", (unsigned long long)now.clipped);
    if (now.unknown != last->unknown)
        hd_log(LOG_WARNING, "triggers named foci the table does not have: %llu in total",
               (unsigned long long)now.unknown);
    if (now.dropped_foci != last->dropped_foci || now.dropped_events != last->dropped_events)
        hd_log(LOG_WARNING, "trigger storm: %llu events and %llu foci dropped in total",
               (unsigned long long)now.dropped_events, (unsigned long long)now.dropped_foci);
    *last = now;
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

static long rss_kib(const char *field)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long v = -1;
    size_t n = strlen(field);
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, field, n))
            v = strtol(line + n + 1, NULL, 10);
    if (f)
        fclose(f);
    return v;
}

void hd_stats_log_chain(const char *table_path, const struct hd_latency_chain *c)
{
    if (isnan(c->lead_s))
        hd_log(LOG_INFO,
               "touch -> focal peak (%s): input path (measured per touch, --latency-report) + queue %.3f ms "
               "(%s) + lead time unknown (the table does not carry it)",
               table_path, 1e3 * c->queue_s, c->queue_why);
    else
        hd_log(LOG_INFO,
               "touch -> focal peak (%s): input path (measured per touch, --latency-report) + queue %.3f ms "
               "(%s) + lead time %.3f ms (table) = %.3f ms + input path",
               table_path, 1e3 * c->queue_s, c->queue_why, 1e3 * c->lead_s, 1e3 * (c->queue_s + c->lead_s));
}

void hd_stats_latency_report(const char *path, struct hd_engine *e, double buffer_latency_s,
                             const struct hd_latency_chain *c)
{
    FILE *f = strcmp(path, "-") ? fopen(path, "w") : stdout;
    if (!f) {
        hd_log(LOG_ERR, "%s: %s", path, strerror(errno));
        return;
    }
    uint32_t n = atomic_load(&e->latency_count);
    qsort(e->latency_ns, n, sizeof *e->latency_ns, cmp_u32);
    const uint32_t *l = e->latency_ns;
    fprintf(f, "triggers %u\n", n);
    if (n) {
        fprintf(f, "latency_p50_us %.1f\nlatency_p99_us %.1f\nlatency_max_us %.1f\n", l[n / 2] / 1e3,
                l[(uint64_t)n * 99 / 100] / 1e3, l[n - 1] / 1e3);
    }
    fprintf(f, "buffer_latency_ms %.3f\n", 1e3 * buffer_latency_s);
    fprintf(f, "queue_ahead_ms %.3f\n", 1e3 * c->queue_s);
    if (isnan(c->lead_s)) {
        fprintf(f, "lead_time_ms unknown\n");
    } else {
        fprintf(f, "lead_time_ms %.3f\n", 1e3 * c->lead_s);
        if (n) /* the measured part (input path, wake-up, render) plus the two fixed ones */
            fprintf(f, "touch_to_peak_p50_ms %.3f\ntouch_to_peak_p99_ms %.3f\n",
                    l[n / 2] / 1e6 + 1e3 * (c->queue_s + c->lead_s),
                    l[(uint64_t)n * 99 / 100] / 1e6 + 1e3 * (c->queue_s + c->lead_s));
    }
    /* RssAnon: heap, stacks and the table buffer; RssFile: mapped libraries. */
    fprintf(f, "vm_rss_kib %ld\nvm_hwm_kib %ld\nrss_anon_kib %ld\nrss_file_kib %ld\n", rss_kib("VmRSS:"),
            rss_kib("VmHWM:"), rss_kib("RssAnon:"), rss_kib("RssFile:"));
    fprintf(f, "table_bytes %zu\n", e->current ? e->current->table.size : 0);
    fprintf(f, "xruns %llu\n", (unsigned long long)atomic_load(&e->stats.xruns));
    fprintf(f, "voices_lowered %llu\nvoices_skipped %llu\n",
            (unsigned long long)atomic_load(&e->stats.voices_attenuated),
            (unsigned long long)atomic_load(&e->stats.voices_skipped));
    fprintf(f, "rewinds %llu\nrewound_frames %llu\n", (unsigned long long)atomic_load(&e->stats.rewinds),
            (unsigned long long)atomic_load(&e->stats.rewound_frames));
    if (f != stdout)
        fclose(f);
}
