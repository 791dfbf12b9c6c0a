/* hapticd: plays time-reversal haptic tables on touch triggers.
 *
 * Threads: main (signals: SIGHUP reload, SIGTERM/SIGINT stop; frees retired
 * tables; logs counters), trigger (GPIO lines and/or the host trigger FIFO,
 * pushes events into the lock-free ring and wakes the audio thread through an
 * eventfd), audio (SCHED_FIFO when allowed: renders and writes one period at
 * a time, and on a trigger rewinds the queued frames to start it at once;
 * never allocates, locks or logs).
 * --script runs the same engine unpaced in one thread for sample-exact tests.
 */
#define _GNU_SOURCE
#include "audio_alsa.h"
#include "board.h"
#include "engine.h"
#include "log.h"
#include "program.h"
#include "rt.h"
#include "trigger.h"
#include "trigger_gpiod.h"

#include <haptic_table.h>

#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <poll.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

struct options {
    const char *board, *table, *triggers, *script, *alsa_device, *latency_report;
    int rt_priority;          /* -1: from the board */
    unsigned tail_frames;
    int drop;                 /* SIGTERM: drop instead of drain */
    int use_syslog;
};

struct daemon {
    struct options opt;
    struct hd_board board;
    struct hd_engine engine;
    struct hd_audio audio;
    struct hd_trigger trigger;
    struct hd_gpio gpio;
    int have_gpio;
    int host_fd;              /* host trigger source, -1 if none */
    int stop_pipe[2];
    int trigger_efd;          /* trigger thread -> audio thread: "an event is in the ring" */
    int timer_fd;             /* clock pacing: the emulated device's period deadline */
    struct pollfd alsa_pfd[HD_AUDIO_MAX_PFDS]; /* device pacing */
    int alsa_pfd_count;
    atomic_int running;       /* audio loop */
    atomic_int accepting;     /* trigger thread pushes events */
    atomic_int audio_failed;
    void *render_buf;         /* one period in the device format */
    double buffer_latency_s;  /* as granted by ALSA */
};

static void usage(FILE *f)
{
    fprintf(f, "usage: hapticd --board boards/NAME/board.ini [--table FILE.htab] [--triggers -|FIFO]\n"
               "               [--script FILE] [--alsa-device PCM] [--rt-priority N] [--drop]\n"
               "               [--tail-frames N] [--latency-report FILE|-] [--syslog]\n"
               "       hapticd --check FILE.htab\n");
}

static int check_table(const char *path)
{
    haptic_table t;
    haptic_table_error err;
    if (haptic_table_open(path, &t, &err) != 0) {
        fprintf(stderr, "hapticd: %s: %s\n", path, err.message);
        return 1;
    }
    haptic_table_print_summary(&t, path, stdout);
    haptic_table_close(&t);
    return 0;
}

/* ---- trigger thread ---- */

/* Hand an event to the audio thread: the lock-free ring, then a wake-up
 * (an eventfd the audio thread polls next to its period clock). */
static void push_trigger(struct daemon *d, const struct hd_event *ev)
{
    if (!atomic_load(&d->accepting) || !hd_spsc_push(&d->engine.ring, ev))
        return;
    if (d->trigger_efd >= 0 && eventfd_write(d->trigger_efd, 1) != 0)
        hd_log(LOG_WARNING, "trigger wake-up: %s", strerror(errno));
}

struct line_reader {
    char buf[512];
    size_t len;
    unsigned line_no;
    int overflow;
};

static void host_line(struct daemon *d, const char *line, unsigned line_no)
{
    struct hd_event ev;
    char err[200];
    int rc = hd_host_parse(line, &ev, err, sizeof err);
    if (rc < 0) {
        hd_log(LOG_WARNING, "triggers %s:%u: %s (ignored)", d->opt.triggers, line_no, err);
        return;
    }
    if (rc == 0)
        return;
    if (ev.frame >= 0) {
        hd_log(LOG_WARNING, "triggers %s:%u: 'at FRAME' needs --script (ignored)", d->opt.triggers, line_no);
        return;
    }
    ev.t_ns = hd_now_ns();
    push_trigger(d, &ev);
}

/* Returns 0 on EOF, 1 if more may come. */
static int host_read(struct daemon *d, struct line_reader *r)
{
    ssize_t n = read(d->host_fd, r->buf + r->len, sizeof r->buf - 1 - r->len);
    if (n < 0)
        return errno == EINTR || errno == EAGAIN ? 1 : 0;
    if (n == 0)
        return 0;
    r->len += (size_t)n;
    char *start = r->buf, *nl;
    while ((nl = memchr(start, '\n', r->len - (size_t)(start - r->buf)))) {
        *nl = '\0';
        r->line_no++;
        if (!r->overflow)
            host_line(d, start, r->line_no);
        r->overflow = 0;
        start = nl + 1;
    }
    r->len -= (size_t)(start - r->buf);
    memmove(r->buf, start, r->len);
    if (r->len == sizeof r->buf - 1) { /* a line longer than the buffer: drop it */
        hd_log(LOG_WARNING, "triggers %s:%u: line longer than %zu bytes (ignored)", d->opt.triggers,
               r->line_no + 1, sizeof r->buf - 2);
        r->len = 0;
        r->overflow = 1;
    }
    return 1;
}

static void *trigger_thread(void *arg)
{
    struct daemon *d = arg;
    struct line_reader reader = {.len = 0};
    struct pollfd pfd[2 + HD_MAX_LINES];
    int host_open = d->host_fd >= 0;
    unsigned read_errors[HD_MAX_LINES] = {0};
    int line_dead[HD_MAX_LINES] = {0};
    for (;;) {
        nfds_t n = 0;
        pfd[n++] = (struct pollfd){.fd = d->stop_pipe[0], .events = POLLIN};
        pfd[n++] = (struct pollfd){.fd = host_open ? d->host_fd : -1, .events = POLLIN};
        for (unsigned i = 0; i < d->gpio.count; i++)
            pfd[n++] = (struct pollfd){.fd = line_dead[i] ? -1 : d->gpio.fds[i], .events = POLLIN};
        if (poll(pfd, n, -1) < 0) {
            if (errno == EINTR)
                continue;
            hd_log(LOG_ERR, "trigger poll: %s", strerror(errno));
            return NULL;
        }
        if (pfd[0].revents)
            return NULL;
        if (host_open && (pfd[1].revents & (POLLIN | POLLHUP)) && !host_read(d, &reader)) {
            hd_log(LOG_INFO, "trigger input %s closed", d->opt.triggers);
            host_open = 0;
        }
        for (unsigned i = 0; i < d->gpio.count; i++) {
            if (pfd[2 + i].revents & (POLLERR | POLLNVAL)) {
                hd_log(LOG_ERR, "GPIO line %u: event fd failed; line disabled", d->gpio.offsets[i]);
                line_dead[i] = 1;
                continue;
            }
            if (!(pfd[2 + i].revents & POLLIN))
                continue;
            struct hd_event ev;
            int rc = hd_gpio_read(&d->gpio, i, &d->trigger, &ev);
            if (rc < 0 && rc != -ENOENT) {
                hd_log(LOG_WARNING, "GPIO line %u: event read failed: %s", d->gpio.offsets[i], strerror(-rc));
                if (++read_errors[i] == 100) { /* not a glitch: stop spinning on it */
                    hd_log(LOG_ERR, "GPIO line %u: 100 read errors in a row; line disabled", d->gpio.offsets[i]);
                    line_dead[i] = 1;
                }
                continue;
            }
            read_errors[i] = 0;
            if (rc == 1)
                push_trigger(d, &ev);
        }
    }
}

/* ---- audio thread ---- */

static void publish_audio_counters(struct daemon *d)
{
    atomic_store_explicit(&d->engine.stats.xruns, d->audio.xruns + d->audio.suspends, memory_order_relaxed);
    atomic_store_explicit(&d->engine.stats.write_errors, d->audio.errors, memory_order_relaxed);
    atomic_store_explicit(&d->engine.stats.rewind_error, d->audio.rewind_error, memory_order_relaxed);
}

/* One period: render, hand to ALSA, note the latency. */
static int audio_step(struct daemon *d)
{
    struct hd_engine *e = &d->engine;
    const uint32_t frames = (uint32_t)d->audio.period_frames;
    hd_engine_period(e, d->render_buf, frames);
    int rc = hd_audio_write(&d->audio, d->render_buf, frames);
    hd_engine_written(e, hd_now_ns());
    publish_audio_counters(d);
    return rc;
}

/* A trigger woke the audio thread: answer it at once. The queued frames the
 * device has not started to read (all but rewind_margin of them) are taken
 * back and rendered again, the new voice starting at the first of them, and
 * written in their place. Nothing to rewind (or a PCM that cannot): the
 * trigger waits in the ring for the next period, as without rewinding. */
static void trigger_step(struct daemon *d)
{
    struct hd_engine *e = &d->engine;
    if (!d->audio.rewind || !hd_engine_pending(e))
        return;
    uint64_t limit = hd_engine_rewindable(e);
    snd_pcm_uframes_t n = hd_audio_rewind(&d->audio, limit < d->audio.buffer_frames ? limit : d->audio.buffer_frames,
                                          hd_now_ns());
    if (n > 0) {
        hd_engine_rewind(e, n);
        while (n > 0) {
            uint32_t chunk = n < d->audio.period_frames ? (uint32_t)n : (uint32_t)d->audio.period_frames;
            hd_engine_period(e, d->render_buf, chunk);
            int rc = hd_audio_write(&d->audio, d->render_buf, chunk);
            hd_engine_written(e, hd_now_ns());
            if (rc < 0)
                break; /* counted; the period clock carries on */
            n -= chunk;
        }
    }
    publish_audio_counters(d);
}

static void drain_fd(int fd)
{
    uint64_t v;
    if (read(fd, &v, sizeof v) < 0) {
        /* EAGAIN: nothing to drain; nothing else can fail on an eventfd/timerfd */
    }
}

static void *audio_thread(void *arg)
{
    struct daemon *d = arg;
    const uint64_t period_ns = (uint64_t)d->audio.period_frames * 1000000000u / d->audio.rate_hz;
    const int clock = d->board.pacing == HD_PACE_CLOCK;
    struct pollfd pfd[2 + HD_AUDIO_MAX_PFDS];
    nfds_t nfds = 0;
    pfd[nfds++] = (struct pollfd){.fd = d->trigger_efd, .events = POLLIN};
    if (clock) {
        pfd[nfds++] = (struct pollfd){.fd = d->timer_fd, .events = POLLIN};
    } else {
        for (int i = 0; i < d->alsa_pfd_count; i++)
            pfd[nfds++] = d->alsa_pfd[i];
    }
    int failures = 0;
    while (atomic_load_explicit(&d->running, memory_order_relaxed)) {
        /* Sleep until a trigger arrives or a period is due: the device has
         * room (device pacing), or the emulated device has played a period
         * (clock pacing: the file/null plugins never block). A period is
         * rendered just before it is written, with the freshest triggers. */
        uint64_t due_ns = 0;
        if (clock) {
            due_ns = hd_audio_clock_due_ns(&d->audio);
            struct itimerspec its = {.it_value = {(time_t)(due_ns / 1000000000u), (long)(due_ns % 1000000000u)}};
            timerfd_settime(d->timer_fd, TFD_TIMER_ABSTIME, &its, NULL);
        }
        for (nfds_t i = 0; i < nfds; i++)
            pfd[i].revents = 0;
        if (poll(pfd, nfds, 100) < 0)
            continue; /* EINTR; re-check running */
        if (pfd[0].revents & POLLIN) {
            drain_fd(d->trigger_efd);
            trigger_step(d);
        }
        int due;
        if (clock) {
            if (pfd[1].revents & POLLIN)
                drain_fd(d->timer_fd);
            due = hd_now_ns() >= due_ns;
        } else {
            due = hd_audio_poll_ready(&d->audio, pfd + 1, d->alsa_pfd_count) != 0; /* room, or an xrun to recover */
        }
        if (!due)
            continue;
        if (audio_step(d) < 0) {
            /* Counted in write_errors and logged by the main thread; back off
             * one period so a dead device does not spin the CPU. */
            if (++failures == 1000)
                atomic_store(&d->audio_failed, 1);
            struct timespec ts = {0, (long)period_ns};
            clock_nanosleep(CLOCK_MONOTONIC, 0, &ts, NULL);
            continue;
        }
        failures = 0;
    }
    return NULL;
}

/* ---- reload, stats, shutdown ---- */

static const char *table_path(const struct daemon *d)
{
    return d->opt.table ? d->opt.table : d->board.table_path;
}

static void reload(struct daemon *d)
{
    struct hd_program *p;
    char err[HD_ERR_MAX];
    hd_engine_collect(&d->engine);
    if (hd_program_load(table_path(d), &d->board, &p, err) != 0) {
        hd_log(LOG_ERR, "reload refused, the current table keeps playing: %s", err);
        return;
    }
    /* The audio thread takes a new table only after the one before the current
     * is retired; wait for that (a signal length at most). */
    int rc = hd_engine_offer(&d->engine, p);
    for (int i = 0; i < 500 && rc == -EBUSY; i++) {
        struct timespec ts = {0, 10000000};
        nanosleep(&ts, NULL);
        hd_engine_collect(&d->engine);
        rc = hd_engine_offer(&d->engine, p);
    }
    if (rc != 0) {
        hd_log(LOG_ERR, "reload refused: the previous reload is still being taken over");
        hd_program_free(p);
        return;
    }
    hd_log(LOG_INFO, "reloaded %s (%u foci, %u channels, %u samples)", table_path(d), p->focus_count,
           p->channel_count, p->samples);
}

struct counters {
    uint64_t xruns, write_errors, stolen, clipped, unknown, dropped_foci, dropped_events;
    int rewind_error;
};

static void log_counters(struct daemon *d, struct counters *last)
{
    struct hd_engine_stats *s = &d->engine.stats;
    struct counters now = {
        .xruns = atomic_load(&s->xruns),
        .write_errors = atomic_load(&s->write_errors),
        .stolen = atomic_load(&s->voices_stolen),
        .clipped = atomic_load(&s->clipped_samples),
        .unknown = atomic_load(&s->unknown_foci),
        .dropped_foci = atomic_load(&s->dropped_foci),
        .dropped_events = atomic_load(&d->engine.ring.dropped),
        .rewind_error = atomic_load(&s->rewind_error),
    };
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

static void latency_report(struct daemon *d)
{
    if (!d->opt.latency_report)
        return;
    FILE *f = strcmp(d->opt.latency_report, "-") ? fopen(d->opt.latency_report, "w") : stdout;
    if (!f) {
        hd_log(LOG_ERR, "%s: %s", d->opt.latency_report, strerror(errno));
        return;
    }
    uint32_t n = atomic_load(&d->engine.latency_count);
    qsort(d->engine.latency_ns, n, sizeof *d->engine.latency_ns, cmp_u32);
    const uint32_t *l = d->engine.latency_ns;
    fprintf(f, "triggers %u\n", n);
    if (n) {
        fprintf(f, "latency_p50_us %.1f\nlatency_p99_us %.1f\nlatency_max_us %.1f\n", l[n / 2] / 1e3,
                l[(uint64_t)n * 99 / 100] / 1e3, l[n - 1] / 1e3);
    }
    fprintf(f, "buffer_latency_ms %.3f\n", 1e3 * d->buffer_latency_s);
    /* RssAnon: heap, stacks and the table buffer; RssFile: mapped libraries. */
    fprintf(f, "vm_rss_kib %ld\nvm_hwm_kib %ld\nrss_anon_kib %ld\nrss_file_kib %ld\n", rss_kib("VmRSS:"),
            rss_kib("VmHWM:"), rss_kib("RssAnon:"), rss_kib("RssFile:"));
    fprintf(f, "table_bytes %zu\n", d->engine.current ? d->engine.current->table.size : 0);
    fprintf(f, "xruns %llu\n", (unsigned long long)atomic_load(&d->engine.stats.xruns));
    fprintf(f, "rewinds %llu\nrewound_frames %llu\n", (unsigned long long)atomic_load(&d->engine.stats.rewinds),
            (unsigned long long)atomic_load(&d->engine.stats.rewound_frames));
    if (f != stdout)
        fclose(f);
}

/* ---- scripted mode ---- */

struct script {
    struct hd_event *events;
    size_t count;
};

static int load_script(const char *path, struct script *s)
{
    FILE *f = strcmp(path, "-") ? fopen(path, "r") : stdin;
    if (!f) {
        hd_log(LOG_ERR, "%s: cannot open script: %s", path, strerror(errno));
        return -1;
    }
    char line[512];
    unsigned no = 0;
    size_t cap = 0;
    int rc = 0;
    memset(s, 0, sizeof *s);
    while (fgets(line, sizeof line, f)) {
        no++;
        struct hd_event ev;
        char err[200];
        int r = hd_host_parse(line, &ev, err, sizeof err);
        if (r == 0)
            continue;
        if (r < 0 || ev.frame < 0) {
            hd_log(LOG_ERR, "%s:%u: %s", path, no, r < 0 ? err : "every script line needs 'at FRAME'");
            rc = -1;
            break;
        }
        if (s->count && ev.frame < s->events[s->count - 1].frame) {
            hd_log(LOG_ERR, "%s:%u: frame %lld is before the previous line's", path, no, (long long)ev.frame);
            rc = -1;
            break;
        }
        if (s->count == cap) {
            cap = cap ? 2 * cap : 64;
            struct hd_event *n = realloc(s->events, cap * sizeof *n);
            if (!n) {
                hd_log(LOG_ERR, "%s: out of memory", path);
                rc = -1;
                break;
            }
            s->events = n;
        }
        s->events[s->count++] = ev;
    }
    if (f != stdin)
        fclose(f);
    if (rc) {
        free(s->events);
        s->events = NULL;
    }
    return rc;
}

/* Unpaced: device frames are counted from the first frame written (the
 * pre-fill included); an event stamped F starts at the first period boundary
 * >= F that is still to be written. Runs until every event has played. */
static int run_script(struct daemon *d, struct script s)
{
    long primed = hd_audio_prime(&d->audio);
    if (primed < 0) {
        hd_log(LOG_ERR, "priming ALSA: %s", snd_strerror((int)primed));
        free(s.events);
        return 1;
    }
    hd_engine_start_at(&d->engine, (uint64_t)primed, 0); /* unpaced: no rewinds, sample-exact starts */
    size_t next = 0;
    uint64_t tail = d->opt.tail_frames, rc = 0;
    while (next < s.count || !hd_engine_idle(&d->engine) || tail > 0) {
        while (next < s.count && (uint64_t)s.events[next].frame <= hd_engine_frame(&d->engine)) {
            s.events[next].t_ns = hd_now_ns();
            hd_spsc_push(&d->engine.ring, &s.events[next++]);
        }
        int busy = next < s.count || !hd_engine_idle(&d->engine);
        if (!busy)
            tail = tail > d->audio.period_frames ? tail - d->audio.period_frames : 0;
        int err = audio_step(d);
        if (err < 0) {
            /* Unpaced runs feed files and tests: the first failure ends the run. */
            hd_log(LOG_ERR, "writing to ALSA device '%s' failed at frame %llu: %s (host-sim: does the WAV's folder exist?)",
                   d->opt.alsa_device ? d->opt.alsa_device : d->board.alsa_device,
                   (unsigned long long)hd_engine_frame(&d->engine), snd_strerror(err));
            rc = 1;
            break;
        }
    }
    hd_log(LOG_INFO, "script done: %llu frames written, %llu voices", (unsigned long long)hd_engine_frame(&d->engine),
           (unsigned long long)atomic_load(&d->engine.stats.voices_started));
    free(s.events);
    return (int)rc;
}

/* ---- main ---- */

static int parse_args(int argc, char **argv, struct options *o)
{
    static const struct option longopts[] = {
        {"board", required_argument, 0, 'b'},        {"table", required_argument, 0, 't'},
        {"triggers", required_argument, 0, 'T'},     {"script", required_argument, 0, 's'},
        {"alsa-device", required_argument, 0, 'D'},  {"rt-priority", required_argument, 0, 'p'},
        {"tail-frames", required_argument, 0, 'f'},  {"latency-report", required_argument, 0, 'L'},
        {"drop", no_argument, 0, 'd'},               {"syslog", no_argument, 0, 'S'},
        {"help", no_argument, 0, 'h'},               {0, 0, 0, 0},
    };
    memset(o, 0, sizeof *o);
    o->rt_priority = -1;
    int c;
    while ((c = getopt_long(argc, argv, "", longopts, NULL)) != -1) {
        char *end;
        switch (c) {
        case 'b': o->board = optarg; break;
        case 't': o->table = optarg; break;
        case 'T': o->triggers = optarg; break;
        case 's': o->script = optarg; break;
        case 'D': o->alsa_device = optarg; break;
        case 'L': o->latency_report = optarg; break;
        case 'd': o->drop = 1; break;
        case 'S': o->use_syslog = 1; break;
        case 'p':
            o->rt_priority = (int)strtol(optarg, &end, 10);
            if (*end || o->rt_priority < 0 || o->rt_priority > 99) {
                fprintf(stderr, "hapticd: --rt-priority: '%s' is not in 0..99\n", optarg);
                return 2;
            }
            break;
        case 'f': {
            unsigned long v = strtoul(optarg, &end, 10);
            if (*end || v > 100000000ul) {
                fprintf(stderr, "hapticd: --tail-frames: '%s' is not in 0..100000000\n", optarg);
                return 2;
            }
            o->tail_frames = (unsigned)v;
            break;
        }
        case 'h': usage(stdout); exit(0);
        default: usage(stderr); return 2;
        }
    }
    if (optind != argc || !o->board) {
        usage(stderr);
        return 2;
    }
    if (o->script && o->triggers) {
        fprintf(stderr, "hapticd: --script and --triggers exclude each other\n");
        return 2;
    }
    return 0;
}

static int open_host_triggers(struct daemon *d)
{
    if (!d->opt.triggers)
        return 0;
    if (!strcmp(d->opt.triggers, "-")) {
        d->host_fd = STDIN_FILENO;
        return 0;
    }
    /* O_RDWR on a FIFO keeps a writer open ourselves: no EOF when a client
     * disconnects, and the open does not block waiting for one. */
    d->host_fd = open(d->opt.triggers, O_RDWR | O_CLOEXEC | O_NONBLOCK);
    if (d->host_fd < 0) {
        hd_log(LOG_ERR, "--triggers %s: %s", d->opt.triggers, strerror(errno));
        return -1;
    }
    return 0;
}

static void stop_live(struct daemon *d, pthread_t audio, pthread_t trig)
{
    atomic_store(&d->accepting, 0);
    if (write(d->stop_pipe[1], "x", 1) < 0)
        hd_log(LOG_WARNING, "stop pipe: %s", strerror(errno));
    pthread_join(trig, NULL);
    if (!d->opt.drop) {
        /* Drain: the voices already playing finish (bounded by one signal
         * length, and by 5 s), then the queued buffer plays out. */
        for (int i = 0; i < 500 && !hd_engine_idle(&d->engine); i++) {
            struct timespec ts = {0, 10000000};
            nanosleep(&ts, NULL);
        }
    }
    atomic_store(&d->running, 0);
    pthread_join(audio, NULL);
}

static int run_live(struct daemon *d)
{
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGHUP);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGINT);
    /* Blocked in every thread (inherited); the main thread takes them synchronously. */
    pthread_sigmask(SIG_BLOCK, &set, NULL);
    long primed = hd_audio_prime(&d->audio);
    if (primed < 0) {
        hd_log(LOG_ERR, "priming ALSA: %s", snd_strerror((int)primed));
        return 1;
    }
    /* Does the PCM rewind? Asked once here, outside the real-time path, so
     * the answer is logged once; a later failure is logged by log_counters. */
    if (d->audio.rewind) {
        snd_pcm_sframes_t can = hd_audio_rewind_probe(&d->audio);
        if (can > 0)
            hd_log(LOG_INFO, "triggers start at once: queued frames rewound, %lu kept (%.3f ms) for the device%s",
                   (unsigned long)d->audio.rewind_margin, 1e3 * (double)d->audio.rewind_margin / d->audio.rate_hz,
                   d->audio.batch ? " (batch device: at least one period)" : "");
        else
            hd_log(LOG_WARNING, "ALSA device cannot rewind (%s): triggers start at the next period boundary",
                   can < 0 ? snd_strerror((int)can) : "no rewindable frames with a full buffer");
        if (d->audio.rewind && d->audio.rewind_margin >= d->audio.buffer_frames)
            hd_log(LOG_WARNING, "[alsa] rewind_margin_frames %lu >= the %lu-frame buffer: nothing is ever rewound",
                   (unsigned long)d->audio.rewind_margin, (unsigned long)d->audio.buffer_frames);
    } else {
        hd_log(LOG_INFO, "[alsa] rewind = false: triggers start at the next period boundary");
    }
    hd_engine_start_at(&d->engine, (uint64_t)primed, d->audio.rewind ? (uint32_t)d->audio.buffer_frames : 0);
    atomic_store(&d->running, 1);
    atomic_store(&d->accepting, 1);
    int prio = d->opt.rt_priority >= 0 ? d->opt.rt_priority : d->board.rt_priority;
    pthread_t audio, trig;
    int is_rt;
    int rc = hd_rt_thread_create(&audio, prio, audio_thread, d, &is_rt);
    const int audio_rt = is_rt;
    if (rc) {
        hd_log(LOG_ERR, "audio thread: %s", strerror(-rc));
        return 1;
    }
    if ((rc = hd_rt_thread_create(&trig, 0, trigger_thread, d, &is_rt)) != 0) {
        hd_log(LOG_ERR, "trigger thread: %s", strerror(-rc));
        atomic_store(&d->running, 0);
        pthread_join(audio, NULL);
        return 1;
    }
    hd_log(LOG_INFO, "running (audio %s)", audio_rt ? "SCHED_FIFO" : "normal priority");
    struct counters last = {0};
    int status = 0;
    for (;;) {
        struct timespec timeout = {0, 200000000};
        int sig = sigtimedwait(&set, NULL, &timeout);
        hd_engine_collect(&d->engine);
        log_counters(d, &last);
        if (sig == SIGHUP)
            reload(d);
        else if (sig == SIGTERM || sig == SIGINT)
            break;
        if (atomic_load(&d->audio_failed)) {
            hd_log(LOG_ERR, "ALSA device keeps failing: giving up");
            status = 1;
            break;
        }
    }
    hd_log(LOG_INFO, "stopping (%s)", d->opt.drop ? "drop" : "drain");
    stop_live(d, audio, trig);
    log_counters(d, &last);
    return status;
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "--check") == 0)
        return check_table(argv[2]);
    static struct daemon d; /* large (ring, latency record): not on the stack */
    int rc = parse_args(argc, argv, &d.opt);
    if (rc)
        return rc;
    signal(SIGPIPE, SIG_IGN);
    hd_log_use_syslog(d.opt.use_syslog);
    char err[HD_ERR_MAX];
    if (hd_board_load(d.opt.board, &d.board, err) != 0) {
        hd_log(LOG_ERR, "%s", err);
        return 1;
    }
    if (!table_path(&d)[0]) {
        hd_log(LOG_ERR, "no table: pass --table or set [table] path in %s", d.board.path);
        return 1;
    }
    struct hd_program *prog;
    if (hd_program_load(table_path(&d), &d.board, &prog, err) != 0) {
        hd_log(LOG_ERR, "%s", err);
        return 1;
    }
    d.host_fd = -1;
    d.stop_pipe[0] = d.stop_pipe[1] = -1;
    d.trigger_efd = d.timer_fd = -1;
    if ((rc = hd_engine_init(&d.engine, &d.board, prog, d.opt.latency_report != NULL)) != 0) {
        hd_log(LOG_ERR, "out of memory");
        hd_program_free(prog);
        return 1;
    }
    int status = 1;
    struct script script = {0};
    /* A bad script fails before the device is opened: no WAV half-written. */
    if (d.opt.script && load_script(d.opt.script, &script))
        goto out_engine;
    if (hd_audio_open(&d.audio, &d.board, d.opt.alsa_device, err) != 0) {
        hd_log(LOG_ERR, "%s", err);
        goto out_engine;
    }
    if (d.audio.period_frames > d.board.period_frames) {
        /* The player's scratch buffer holds the board's period; refuse more. */
        hd_log(LOG_ERR, "ALSA granted %lu-frame periods, the board asks %u", (unsigned long)d.audio.period_frames,
               d.board.period_frames);
        goto out_audio;
    }
    d.buffer_latency_s = (double)d.audio.buffer_frames / d.audio.rate_hz;
    hd_audio_configure(&d.audio, !d.opt.script && d.board.rewind, d.board.rewind_margin_frames,
                       d.board.pacing == HD_PACE_CLOCK);
    d.render_buf = calloc(d.audio.period_frames, d.audio.frame_bytes);
    if (!d.render_buf)
        goto out_audio;
    hd_log(LOG_INFO, "%s: %u ch %s %u Hz, period %lu frames, buffer %lu frames = %.3f ms buffer latency; table %s",
           d.opt.alsa_device ? d.opt.alsa_device : d.board.alsa_device, d.board.channels,
           hd_format_name(d.board.format), d.audio.rate_hz, (unsigned long)d.audio.period_frames,
           (unsigned long)d.audio.buffer_frames, 1e3 * (double)d.audio.buffer_frames / d.audio.rate_hz,
           table_path(&d));
    if (d.opt.script) {
        status = run_script(&d, script);
        script.events = NULL;
        hd_audio_close(&d.audio, 1);
        goto out_report;
    }
    hd_trigger_init(&d.trigger, &d.board);
    if (d.board.line_count > 0) {
        if (hd_gpio_open(&d.gpio, &d.board, err) != 0) {
            hd_log(LOG_ERR, "%s", err);
            goto out_audio;
        }
        d.have_gpio = 1;
    }
    if (open_host_triggers(&d) != 0 || pipe2(d.stop_pipe, O_CLOEXEC) != 0)
        goto out_gpio;
    d.trigger_efd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (d.trigger_efd < 0) {
        hd_log(LOG_ERR, "eventfd: %s", strerror(errno));
        goto out_gpio;
    }
    if (d.board.pacing == HD_PACE_CLOCK) {
        d.timer_fd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
        if (d.timer_fd < 0) {
            hd_log(LOG_ERR, "timerfd: %s", strerror(errno));
            goto out_gpio;
        }
    } else if ((d.alsa_pfd_count = hd_audio_poll_fds(&d.audio, d.alsa_pfd, HD_AUDIO_MAX_PFDS)) < 0) {
        hd_log(LOG_ERR, "ALSA poll descriptors: %s", snd_strerror(d.alsa_pfd_count));
        goto out_gpio;
    }
    if (d.board.mlock)
        hd_rt_lock_memory();
    status = run_live(&d);
    hd_audio_close(&d.audio, !d.opt.drop);
out_gpio:
    if (d.have_gpio)
        hd_gpio_close(&d.gpio);
    if (d.host_fd > STDIN_FILENO)
        close(d.host_fd);
    for (int i = 0; i < 2; i++)
        if (d.stop_pipe[i] >= 0)
            close(d.stop_pipe[i]);
    if (d.trigger_efd >= 0)
        close(d.trigger_efd);
    if (d.timer_fd >= 0)
        close(d.timer_fd);
out_report:
    latency_report(&d);
out_audio:
    hd_audio_close(&d.audio, 0);
    free(d.render_buf);
out_engine:
    free(script.events);
    hd_engine_free(&d.engine);
    return status;
}
