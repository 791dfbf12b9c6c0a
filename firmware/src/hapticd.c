/* hapticd: plays time-reversal haptic tables on touch triggers.
 *
 * This file is the shell: options, start-up, threads, signals, shutdown.
 * Threads: main (signals: SIGHUP reload, SIGTERM/SIGINT stop; frees retired
 * tables; logs counters, stats.c; which table plays, reloaded or stretched
 * again for the panel temperature, table_policy.c), trigger (trigger_loop.c),
 * audio (audio_loop.c, SCHED_FIFO when allowed). --script runs the same
 * engine unpaced in one thread for sample-exact tests (script.c,
 * audio_loop.c).
 */
#define _GNU_SOURCE
#include "audio_alsa.h"
#include "audio_loop.h"
#include "board.h"
#include "control.h"
#include "engine.h"
#include "exciter_report.h"
#include "log.h"
#include "measure.h"
#include "program.h"
#include "rt.h"
#include "script.h"
#include "stats.h"
#include "table_policy.h"
#include "trigger.h"
#include "trigger_evdev.h"
#include "trigger_gpiod.h"
#include "trigger_loop.h"

#include <haptic_table.h>

#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <math.h>
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
    const char *board, *table, *triggers, *script, *alsa_device, *latency_report, *touch_device;
    const char *measure, *capture; /* --measure PLAN.wav --capture REC.wav (measure.h) */
    int rt_priority;               /* -1: from the board */
    unsigned tail_frames;
    int drop; /* SIGTERM: drop instead of drain */
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
    struct hd_evdev evdev;
    struct hd_touch touch;
    int have_touch;
    int stop_pipe[2];
    struct hd_trigger_loop triggers;
    struct hd_audio_loop player;
    struct hd_table_policy tables; /* which table plays (main thread) */
    atomic_int accepting;          /* the trigger thread's events are taken */
    struct hd_latency_chain chain; /* touch -> focal peak, for the current table */
    int rewind_at_start;           /* the PCM rewinds (probed before the threads start) */
    double buffer_latency_s;       /* as granted by ALSA */
    unsigned long lib_pending;     /* libasound messages not logged yet */
    char lib_pending_first[512];   /* the first of them */
    double lib_next_log_s;         /* no libasound line before this time */
    struct hd_control control;     /* the user's intensity file ([control] intensity_file) */
    int control_failing;           /* its last look failed (logged once per failing stretch) */
};

static void usage(FILE *f)
{
    fprintf(f, "usage: hapticd --board boards/NAME/board.ini [--table FILE.htab] [--triggers -|FIFO]\n"
               "               [--script FILE] [--alsa-device PCM] [--touch-device PATH] [--rt-priority N] [--drop]\n"
               "               [--tail-frames N] [--latency-report FILE|-] [--syslog]\n"
               "       hapticd --board boards/NAME/board.ini --measure PLAN.wav --capture REC.wav [--alsa-device PCM]\n"
               "       hapticd --check FILE.htab [--board boards/NAME/board.ini]\n");
}

/* --check: the table's summary; with a board, also whether the board takes
 * it (rate, channels) and what each focus costs its exciters. The table is
 * read once: by the program when a board is given. */
static int check_table(const char *path, const char *board_path)
{
    if (!board_path) {
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
    static struct hd_board board;
    struct hd_program *p = NULL;
    char why[HD_ERR_MAX];
    int rc = hd_board_load(board_path, &board, why);
    if (rc == 0)
        rc = hd_program_load(path, &board, &p, why);
    if (rc == 0) {
        haptic_table_print_summary(&p->table, path, stdout);
        rc = hd_exciter_report(p, &board, board_path, stdout, why);
    }
    hd_program_free(p);
    if (rc != 0) {
        fprintf(stderr, "hapticd: %s\n", why);
        return 1;
    }
    return 0;
}

/* Hand an event to the audio thread: the lock-free ring, then a wake-up
 * (an eventfd the audio thread polls next to its period clock). */
static void push_trigger(void *ctx, const struct hd_event *ev)
{
    struct daemon *d = ctx;
    if (!atomic_load(&d->accepting) || !hd_spsc_push(&d->engine.ring, ev))
        return;
    if (d->player.trigger_efd >= 0 && eventfd_write(d->player.trigger_efd, 1) != 0)
        hd_log(LOG_WARNING, "trigger wake-up: %s", strerror(errno));
}

/* The fixed parts of touch -> focal peak for program p (stats.h). The
 * audio thread may switch rewinding off (it owns d->audio then): the main
 * thread reads that from the published rewind_error only. */
static void chain_for(struct daemon *d, const struct hd_program *p, int rewinding)
{
    const double rate = d->audio.rate_hz;
    if (rewinding && !atomic_load(&d->engine.stats.rewind_error)) {
        d->chain.queue_s = (double)d->audio.rewind_margin / rate;
        d->chain.queue_why = "rewind margin";
    } else {
        d->chain.queue_s = (double)d->audio.buffer_frames / rate;
        d->chain.queue_why = d->opt.script ? "scripted: the buffer" : "no rewinding: the buffer";
    }
    d->chain.lead_s = hd_program_lead_time_s(p);
}

static const char *table_path(const struct daemon *d) { return d->opt.table ? d->opt.table : d->board.table_path; }

/* After each table the policy hands over (table_policy.h): the touchscreen
 * takes the new foci at its next event, and the touch -> focal peak chain
 * is the new table's. */
static void table_handed_over(void *ctx, const struct hd_program *p)
{
    struct daemon *d = ctx;
    if (d->have_touch) {
        struct hd_touch_foci *f = hd_touch_foci_of(&p->table);
        if (!f)
            hd_log(LOG_ERR, "touch input keeps the previous foci: out of memory");
        else
            free(atomic_exchange(&d->triggers.next_foci, f));
    }
    chain_for(d, p, d->rewind_at_start);
    hd_stats_log_chain(table_path(d), &d->chain);
}

static double monotonic_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---- main ---- */

static int parse_args(int argc, char **argv, struct options *o)
{
    static const struct option longopts[] = {
        {"board", required_argument, 0, 'b'},
        {"table", required_argument, 0, 't'},
        {"triggers", required_argument, 0, 'T'},
        {"script", required_argument, 0, 's'},
        {"alsa-device", required_argument, 0, 'D'},
        {"rt-priority", required_argument, 0, 'p'},
        {"touch-device", required_argument, 0, 'U'},
        {"tail-frames", required_argument, 0, 'f'},
        {"latency-report", required_argument, 0, 'L'},
        {"drop", no_argument, 0, 'd'},
        {"syslog", no_argument, 0, 'S'},
        {"measure", required_argument, 0, 'M'},
        {"capture", required_argument, 0, 'C'},
        {"help", no_argument, 0, 'h'},
        {0, 0, 0, 0},
    };
    memset(o, 0, sizeof *o);
    o->rt_priority = -1;
    int c;
    while ((c = getopt_long(argc, argv, "", longopts, NULL)) != -1) {
        char *end;
        switch (c) {
        case 'b':
            o->board = optarg;
            break;
        case 't':
            o->table = optarg;
            break;
        case 'T':
            o->triggers = optarg;
            break;
        case 's':
            o->script = optarg;
            break;
        case 'M':
            o->measure = optarg;
            break;
        case 'C':
            o->capture = optarg;
            break;
        case 'D':
            o->alsa_device = optarg;
            break;
        case 'U':
            o->touch_device = optarg;
            break;
        case 'L':
            o->latency_report = optarg;
            break;
        case 'd':
            o->drop = 1;
            break;
        case 'S':
            o->use_syslog = 1;
            break;
        case 'p': {
            /* Range-checked in strtol's full width before narrowing:
             * 4294967376 must not become 80. */
            errno = 0;
            long v = strtol(optarg, &end, 10);
            if (end == optarg || *end || errno || v < 0 || v > 99) {
                fprintf(stderr, "hapticd: --rt-priority: '%s' is not in 0..99\n", optarg);
                return 2;
            }
            o->rt_priority = (int)v;
            break;
        }
        case 'f': {
            unsigned long v = strtoul(optarg, &end, 10);
            if (*end || v > 100000000ul) {
                fprintf(stderr, "hapticd: --tail-frames: '%s' is not in 0..100000000\n", optarg);
                return 2;
            }
            o->tail_frames = (unsigned)v;
            break;
        }
        case 'h':
            usage(stdout);
            exit(0);
        default:
            usage(stderr);
            return 2;
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
    if (!o->measure != !o->capture) {
        fprintf(stderr, "hapticd: --measure PLAN.wav and --capture REC.wav go together\n");
        return 2;
    }
    if (o->measure && (o->script || o->triggers || o->table || o->touch_device || o->latency_report)) {
        fprintf(stderr, "hapticd: --measure plays a plan, not a table: no --table, --script, --triggers, "
                        "--touch-device or --latency-report with it\n");
        return 2;
    }
    return 0;
}

/* The touchscreen plays the table's foci at the positions the table gives
 * them; a later table hands it its own (table_handed_over()). */
static int open_touch(struct daemon *d, char err[HD_ERR_MAX])
{
    struct hd_touch_foci *f = hd_touch_foci_of(&d->engine.current->table);
    if (!f) {
        snprintf(err, HD_ERR_MAX, "touch input: out of memory");
        return -ENOMEM;
    }
    int rc = hd_evdev_open(&d->evdev, &d->board.touch, d->board.path, d->opt.touch_device, &d->touch, f->count, f->id,
                           f->xy_m, err);
    free(f);
    if (rc == 0)
        hd_log(LOG_INFO, "touch device %s ('%s'): %s, %u foci, max_distance %.3f m, hysteresis %.4f m", d->evdev.path,
               d->evdev.name, d->touch.multitouch ? "multi-touch (protocol B)" : "single touch", d->touch.focus_count,
               d->touch.max_distance_m, d->touch.hysteresis_m);
    return rc;
}

static int open_host_triggers(struct daemon *d)
{
    if (!d->opt.triggers)
        return 0;
    if (!strcmp(d->opt.triggers, "-")) {
        d->triggers.host_fd = STDIN_FILENO;
        return 0;
    }
    /* O_RDWR on a FIFO keeps a writer open ourselves: no EOF when a client
     * disconnects, and the open does not block waiting for one. */
    d->triggers.host_fd = open(d->opt.triggers, O_RDWR | O_CLOEXEC | O_NONBLOCK);
    if (d->triggers.host_fd < 0) {
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
    atomic_store(&d->player.running, 0);
    pthread_join(audio, NULL);
}

static const char *device_name(const struct daemon *d)
{
    return d->opt.alsa_device ? d->opt.alsa_device : d->board.alsa_device;
}

/* libasound's own messages (audio_alsa.h), through hapticd's log: the first
 * of a burst, then at most one summary each 10 s. */
static void log_lib_messages(struct daemon *d)
{
    char first[512];
    unsigned long n = hd_audio_lib_messages_take(first, sizeof first);
    d->lib_pending += n;
    if (!first[0] && !d->lib_pending_first[0])
        return;
    if (first[0] && !d->lib_pending_first[0])
        snprintf(d->lib_pending_first, sizeof d->lib_pending_first, "%s", first);
    const double now = monotonic_s();
    if (now < d->lib_next_log_s)
        return;
    if (d->lib_pending > 1)
        hd_log(LOG_WARNING, "libasound: %s (%lu messages from it since the last report)", d->lib_pending_first,
               d->lib_pending);
    else
        hd_log(LOG_WARNING, "libasound: %s", d->lib_pending_first);
    d->lib_pending = 0;
    d->lib_pending_first[0] = '\0';
    d->lib_next_log_s = now + 10.0;
}

/* The user's intensity (control.h): a new level is handed to the player
 * for the voices to come; a bad or missing file keeps the level, said once
 * until the file is good again. With a table that gives the foci's safe
 * ranges (format 1.3), what their clamp does at the new level is said in
 * the same breath (hd_program_range_note). 1: a new level was taken. */
static int poll_control(struct daemon *d)
{
    if (!d->control.path[0])
        return 0;
    char err[HD_ERR_MAX];
    double db;
    int rc = hd_control_poll(&d->control, &db, err);
    if (rc < 0) {
        if (!d->control_failing)
            hd_log(LOG_WARNING, "intensity: %s: the level stays %+.1f dB", err,
                   20 * log10(hd_player_level(&d->engine.player)));
        d->control_failing = 1;
        return 0;
    }
    if (rc == 0)
        return 0;
    d->control_failing = 0;
    const double level = pow(10.0, db / 20.0);
    hd_player_set_level(&d->engine.player, level);
    const int above_limit = level > d->board.gain_limit;
    if (above_limit)
        hd_log(LOG_INFO, "intensity %+.1f dB: above [mixer] gain_limit (%+.1f dB), voices play at most at it", db,
               20 * log10(d->board.gain_limit));
    if (!hd_table_policy_log_range(&d->tables, level) && !above_limit)
        hd_log(LOG_INFO, "intensity %+.1f dB", db);
    return 1;
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
     * the answer is logged once; a later failure is logged by hd_stats_log. */
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
    d->rewind_at_start = d->audio.rewind;
    chain_for(d, d->engine.current, d->rewind_at_start);
    hd_stats_log_chain(table_path(d), &d->chain);
    hd_engine_start_at(&d->engine, (uint64_t)primed, d->audio.rewind ? (uint32_t)d->audio.buffer_frames : 0);
    atomic_store(&d->player.running, 1);
    atomic_store(&d->accepting, 1);
    int prio = d->opt.rt_priority >= 0 ? d->opt.rt_priority : d->board.rt_priority;
    pthread_t audio, trig;
    int is_rt;
    int rc = hd_rt_thread_create(&audio, prio, hd_audio_loop_run, &d->player, &is_rt);
    const int audio_rt = is_rt;
    if (rc) {
        hd_log(LOG_ERR, "audio thread: %s", strerror(-rc));
        return 1;
    }
    if ((rc = hd_rt_thread_create(&trig, 0, hd_trigger_loop_run, &d->triggers, &is_rt)) != 0) {
        hd_log(LOG_ERR, "trigger thread: %s", strerror(-rc));
        atomic_store(&d->player.running, 0);
        pthread_join(audio, NULL);
        return 1;
    }
    hd_log(LOG_INFO, "running (audio %s)", audio_rt ? "SCHED_FIFO" : "normal priority");
    struct hd_counters last = {0};
    int status = 0;
    for (;;) {
        struct timespec timeout = {0, 200000000};
        int sig = sigtimedwait(&set, NULL, &timeout);
        hd_engine_collect(&d->engine);
        hd_stats_log(&d->engine, &last);
        if (sig == SIGHUP)
            hd_table_policy_reload(&d->tables);
        else if (sig == SIGTERM || sig == SIGINT)
            break;
        hd_table_policy_poll(&d->tables, monotonic_s());
        poll_control(d);
        log_lib_messages(d);
        const int failed = atomic_load(&d->player.failed);
        if (failed) {
            if (failed == HD_AUDIO_UNPACED)
                hd_log(LOG_ERR,
                       "ALSA device '%s' takes frames faster than real time: it does not pace the stream "
                       "([alsa] pacing = device in %s; a plugin such as null or file needs pacing = clock)",
                       device_name(d), d->board.path);
            else
                hd_log(LOG_ERR, "ALSA device '%s' failed for %.0f s without a second's rest: giving up", device_name(d),
                       (double)HD_AUDIO_GIVE_UP_NS * 1e-9);
            d->opt.drop = 1; /* nothing plays the voices in flight any more */
            status = 1;
            break;
        }
    }
    hd_log(LOG_INFO, "stopping (%s)", d->opt.drop ? "drop" : "drain");
    stop_live(d, audio, trig);
    hd_stats_log(&d->engine, &last);
    return status;
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "--check") == 0)
        return check_table(argv[2], NULL);
    if (argc == 5 && strcmp(argv[1], "--check") == 0 && strcmp(argv[3], "--board") == 0)
        return check_table(argv[2], argv[4]);
    /* SIGHUP and SIGTERM wait from the first instruction on: blocked here
     * (every thread inherits the mask), taken by run_live's sigtimedwait.
     * One that comes while the daemon starts is acted on as soon as it runs
     * (a reload of what was just loaded, or a stop) instead of killing it
     * without a word, which systemd would count as a clean exit. */
    sigset_t early;
    sigemptyset(&early);
    sigaddset(&early, SIGHUP);
    sigaddset(&early, SIGTERM);
    sigaddset(&early, SIGINT);
    sigprocmask(SIG_BLOCK, &early, NULL);
    static struct daemon d; /* large (ring, latency record): not on the stack */
    int rc = parse_args(argc, argv, &d.opt);
    if (rc)
        return rc;
    signal(SIGPIPE, SIG_IGN);
    hd_log_use_syslog(d.opt.use_syslog);
    hd_audio_lib_messages_capture();
    char err[HD_ERR_MAX];
    if (hd_board_load(d.opt.board, &d.board, err) != 0) {
        hd_log(LOG_ERR, "%s", err);
        return 1;
    }
    if (d.opt.measure) /* a mode of its own: no table, no threads (measure.h) */
        return hd_measure_run(&d.board, d.opt.measure, d.opt.capture, d.opt.alsa_device);
    if (!table_path(&d)[0]) {
        hd_log(LOG_ERR, "no table: pass --table or set [table] path in %s", d.board.path);
        return 1;
    }
    struct hd_program *prog;
    if (hd_table_policy_open(&d.tables, &d.board, table_path(&d), monotonic_s(), &prog, err) != 0) {
        hd_log(LOG_ERR, "%s", err);
        return 1;
    }
    d.triggers.host_fd = -1;
    d.stop_pipe[0] = d.stop_pipe[1] = -1;
    d.player.trigger_efd = d.player.timer_fd = -1;
    d.player.engine = &d.engine;
    d.player.audio = &d.audio;
    d.player.clock_paced = d.board.pacing == HD_PACE_CLOCK;
    if ((rc = hd_engine_init(&d.engine, &d.board, prog, d.opt.latency_report != NULL)) != 0) {
        hd_log(LOG_ERR, "out of memory");
        hd_program_free(prog);
        return 1;
    }
    hd_table_policy_attach(&d.tables, &d.engine, table_handed_over, &d);
    int status = 1;
    struct hd_script script = {0};
    /* A bad script fails before the device is opened: no WAV half-written. */
    if (d.opt.script && hd_script_load(d.opt.script, &script, err) != 0) {
        hd_log(LOG_ERR, "%s", err);
        goto out_engine;
    }
    if (hd_audio_open(&d.audio, &d.board, d.opt.alsa_device, err) != 0) {
        /* One line: hapticd's, with libasound's first word on it. */
        char lib[512];
        if (hd_audio_lib_messages_take(lib, sizeof lib) && lib[0])
            hd_log(LOG_ERR, "%s (libasound: %s)", err, lib);
        else
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
    d.player.render_buf = calloc(d.audio.period_frames, d.audio.frame_bytes);
    if (!d.player.render_buf)
        goto out_audio;
    hd_log(LOG_INFO, "%s: %u ch %s %u Hz, period %lu frames, buffer %lu frames = %.3f ms buffer latency; table %s",
           d.opt.alsa_device ? d.opt.alsa_device : d.board.alsa_device, d.board.channels,
           hd_format_name(d.board.format), d.audio.rate_hz, (unsigned long)d.audio.period_frames,
           (unsigned long)d.audio.buffer_frames, 1e3 * (double)d.audio.buffer_frames / d.audio.rate_hz, table_path(&d));
    if (d.opt.script) {
        /* Unpaced and short: a signal ends it as it always did. */
        sigprocmask(SIG_UNBLOCK, &early, NULL);
        chain_for(&d, d.engine.current, 0);
        hd_table_policy_log_range(&d.tables, hd_player_level(&d.engine.player));
        status = hd_audio_loop_script(&d.player, &script, d.opt.tail_frames,
                                      d.opt.alsa_device ? d.opt.alsa_device : d.board.alsa_device);
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
    if (d.opt.touch_device && !d.board.touch.enabled) {
        hd_log(LOG_ERR, "--touch-device %s: the board %s has no [touch] section (the panel -> plate map)",
               d.opt.touch_device, d.board.path);
        goto out_gpio;
    }
    if (d.board.touch.enabled) {
        if (open_touch(&d, err) != 0) {
            hd_log(LOG_ERR, "%s", err);
            goto out_gpio;
        }
        d.have_touch = 1;
    }
    if (open_host_triggers(&d) != 0 || pipe2(d.stop_pipe, O_CLOEXEC) != 0)
        goto out_gpio;
    d.player.trigger_efd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (d.player.trigger_efd < 0) {
        hd_log(LOG_ERR, "eventfd: %s", strerror(errno));
        goto out_gpio;
    }
    if (d.board.pacing == HD_PACE_CLOCK) {
        d.player.timer_fd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
        if (d.player.timer_fd < 0) {
            hd_log(LOG_ERR, "timerfd: %s", strerror(errno));
            goto out_gpio;
        }
    } else if ((d.player.alsa_pfd_count = hd_audio_poll_fds(&d.audio, d.player.alsa_pfd, HD_AUDIO_MAX_PFDS)) < 0) {
        hd_log(LOG_ERR, "ALSA poll descriptors: %s", snd_strerror(d.player.alsa_pfd_count));
        goto out_gpio;
    }
    d.triggers = (struct hd_trigger_loop){
        .stop_fd = d.stop_pipe[0],
        .host_fd = d.triggers.host_fd,
        .host_name = d.opt.triggers,
        .gpio = d.have_gpio ? &d.gpio : NULL,
        .evdev = d.have_touch ? &d.evdev : NULL,
        .touch = &d.touch,
        .trigger = &d.trigger,
        .push = push_trigger,
        .push_ctx = &d,
    };
    if (d.board.mlock)
        hd_rt_lock_memory();
    snprintf(d.control.path, sizeof d.control.path, "%s", d.board.intensity_file);
    if (!poll_control(&d)) /* the level before the first touch; said with the range's clamp when read */
        hd_table_policy_log_range(&d.tables, hd_player_level(&d.engine.player));
    status = run_live(&d);
    hd_audio_close(&d.audio, !d.opt.drop);
out_gpio:
    if (d.have_gpio)
        hd_gpio_close(&d.gpio);
    if (d.have_touch)
        hd_evdev_close(&d.evdev);
    free(atomic_exchange(&d.triggers.next_foci, NULL));
    if (d.triggers.host_fd > STDIN_FILENO)
        close(d.triggers.host_fd);
    for (int i = 0; i < 2; i++)
        if (d.stop_pipe[i] >= 0)
            close(d.stop_pipe[i]);
    if (d.player.trigger_efd >= 0)
        close(d.player.trigger_efd);
    if (d.player.timer_fd >= 0)
        close(d.player.timer_fd);
out_report:
    if (d.opt.latency_report)
        hd_stats_latency_report(d.opt.latency_report, &d.engine, d.buffer_latency_s, &d.chain);
out_audio:
    hd_audio_close(&d.audio, 0);
    free(d.player.render_buf);
out_engine:
    hd_script_free(&script);
    hd_engine_free(&d.engine);
    return status;
}
