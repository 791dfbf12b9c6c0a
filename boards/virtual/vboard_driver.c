/* vboard-driver: the guest side of scripts/virtual-board.
 *
 *   vboard-driver make-table OUT.htab
 *   vboard-driver run --hapticd EXE --board INI --table HTAB [--tick-hz HZ] [--touch]
 *
 * `run` starts hapticd on the board (snd-aloop's playback side), records the
 * capture side, sends triggers through hapticd's host trigger FIFO (and with
 * --touch, touches through a uinput panel), provokes a capture overrun and a
 * playback underrun, stops hapticd, and checks every voice in the recording
 * against the table. Then it plays a storm of triggers on the board with
 * exciter ratings and checks the recorded heat against them. Last, it starts
 * hapticd again and removes the loopback card under it while it plays (the
 * snd-aloop platform device unbound from its driver): hapticd must give up
 * on the failed device and exit 1.
 * One "vboard: PASS|FAIL name: detail" line per check; exit status 1 if any
 * failed. */
#define _GNU_SOURCE
#include "vboard.h"

#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <libgen.h>
#include <limits.h>
#include <math.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

extern char **environ;

#define FIFO_PATH "/tmp/vboard-triggers"
#define LOG_PATH "/tmp/hapticd.log"
#define FAILING_LOG_PATH "/tmp/hapticd-failing.log" /* the failing-device run's stderr */
#define FAILING_OUT_PATH "/tmp/hapticd-failing.out" /* and its stdout */
#define LATENCY_PATH "/tmp/hapticd-latency.txt"
#define CAPTURE_PCM "hw:Loopback,1,0" /* snd-aloop: what hw:Loopback,0,0 plays */
#define SPACING_MS 250                /* between triggers: a 50 ms voice and a silent gap */
#define MAX_EXPECT 16

struct run {
    const char *hapticd, *board, *table_path;
    const char *log; /* hapticd's stderr (LOG_PATH, or FAILING_LOG_PATH) */
    int touch;
    unsigned tick_hz;
    haptic_table table;
    pid_t pid;
    int fifo;
    struct vb_capture cap;
    struct vb_touch panel;
    struct vb_expect expect[MAX_EXPECT];
    unsigned expect_count, touch_first; /* expect[touch_first..] are touches */
};

static void sleep_ms(int ms)
{
    struct timespec ts = {ms / 1000, (long)(ms % 1000) * 1000000};
    while (nanosleep(&ts, &ts) && errno == EINTR) {
    }
}

static char *read_text(const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return NULL;
    static char buf[1 << 16];
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    buf[n] = '\0';
    fclose(f);
    return buf;
}

static int log_has(const struct run *r, const char *needle)
{
    const char *text = read_text(r->log);
    return text && strstr(text, needle);
}

/* hapticd's stderr goes to r->log; its stdout to out_path, or with it. */
static int start_hapticd(struct run *r, const char *out_path)
{
    unlink(FIFO_PATH);
    if (mkfifo(FIFO_PATH, 0600) != 0)
        return -errno;
    char *argv[] = {(char *)r->hapticd, "--board", (char *)r->board,   "--table",    (char *)r->table_path,
                    "--triggers",       FIFO_PATH, "--latency-report", LATENCY_PATH, NULL};
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 2, r->log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (out_path)
        posix_spawn_file_actions_addopen(&fa, 1, out_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    else
        posix_spawn_file_actions_adddup2(&fa, 2, 1);
    int rc = posix_spawn(&r->pid, r->hapticd, &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc)
        return -rc;
    /* Under emulation start-up takes a while; hapticd says when it runs. */
    for (int i = 0; i < 300; i++) {
        if (log_has(r, "running ("))
            break;
        int st;
        if (waitpid(r->pid, &st, WNOHANG) == r->pid) {
            r->pid = 0;
            return -ECHILD;
        }
        sleep_ms(50);
    }
    if (!log_has(r, "running ("))
        return -ETIMEDOUT;
    /* hapticd holds the FIFO open read-write: this open does not block. */
    r->fifo = open(FIFO_PATH, O_WRONLY | O_CLOEXEC);
    return r->fifo < 0 ? -errno : 0;
}

static int stop_hapticd(struct run *r)
{
    if (r->pid <= 0)
        return -1;
    kill(r->pid, SIGTERM);
    for (int i = 0; i < 200; i++) {
        int st;
        if (waitpid(r->pid, &st, WNOHANG) == r->pid) {
            r->pid = 0;
            return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        }
        sleep_ms(50);
    }
    kill(r->pid, SIGKILL);
    waitpid(r->pid, NULL, 0);
    r->pid = 0;
    return -1;
}

/* One host trigger command; its time is taken just before the write. */
static void trigger_then(struct run *r, const char *name, const char *command, unsigned count, uint32_t a, uint32_t b,
                         int wait_ms)
{
    if (r->expect_count == MAX_EXPECT)
        return;
    struct vb_expect *e = &r->expect[r->expect_count++];
    *e = (struct vb_expect){.name = name, .index = {a, b}, .count = count};
    char line[64];
    int n = snprintf(line, sizeof line, "%s\n", command);
    e->t_ns = vb_now_ns();
    if (write(r->fifo, line, (size_t)n) != n)
        vb_result(0, name, "writing the trigger FIFO: %s", strerror(errno));
    sleep_ms(wait_ms);
}

static void trigger(struct run *r, const char *name, const char *command, unsigned count, uint32_t a, uint32_t b)
{
    trigger_then(r, name, command, count, a, b, SPACING_MS);
}

/* A touch at panel coordinates; its time is the kernel's timestamp of the
 * input frame (read back from the panel's evdev node). */
static void touch(struct run *r, const char *name, unsigned count, const int *x, const int *y, uint32_t a, uint32_t b)
{
    if (r->expect_count == MAX_EXPECT)
        return;
    struct vb_expect *e = &r->expect[r->expect_count++];
    *e = (struct vb_expect){.name = name, .index = {a, b}, .count = count};
    int pos[2][2];
    int rc = vb_touch_down(&r->panel, count, x, y);
    if (!rc)
        rc = vb_touch_read_frame(&r->panel, 1000, &e->t_ns, pos);
    sleep_ms(30);
    if (!rc)
        rc = vb_touch_up(&r->panel, count);
    uint64_t up_ns;
    if (!rc)
        rc = vb_touch_read_frame(&r->panel, 1000, &up_ns, pos);
    if (rc)
        vb_result(0, name, "uinput: %s", strerror(-rc));
    sleep_ms(SPACING_MS - 30);
}

/* The panel's axes span the synthetic table's 0.2 m x 0.15 m plate
 * (boards/virtual/touch.ini); a touch on a focus plays it. */
static void focus_on_panel(const haptic_table *t, uint32_t index, int *x, int *y)
{
    haptic_focus_info f;
    haptic_table_focus(t, index, &f);
    *x = (int)lround(f.x_m / 0.2 * VB_TOUCH_X_MAX);
    *y = (int)lround(f.y_m / 0.15 * VB_TOUCH_Y_MAX);
}

static void check_uinput(struct run *r)
{
    int rc = vb_touch_open(&r->panel);
    if (rc) {
        vb_result(0, "uinput panel", "creating %s: %s", VB_TOUCH_NAME, strerror(-rc));
        return;
    }
    int x[1] = {1234}, y[1] = {2345}, pos[2][2] = {{-1, -1}, {-1, -1}};
    uint64_t before = vb_now_ns(), t_ns = 0, up_ns = 0;
    rc = vb_touch_down(&r->panel, 1, x, y);
    uint64_t after = vb_now_ns();
    if (!rc)
        rc = vb_touch_read_frame(&r->panel, 1000, &t_ns, pos);
    if (!rc && !(rc = vb_touch_up(&r->panel, 1)))
        rc = vb_touch_read_frame(&r->panel, 1000, &up_ns, (int[2][2]){{0}});
    /* evdev stamps in microseconds: allow the truncation. */
    int ok = !rc && pos[0][0] == x[0] && pos[0][1] == y[0] && t_ns + 1000 >= before && t_ns <= after;
    vb_result(ok, "uinput panel", "%s: contact at (%d, %d) read back as (%d, %d), stamped %.3f ms into the write%s%s",
              r->panel.evdev_path, x[0], y[0], pos[0][0], pos[0][1], ((double)t_ns - (double)before) / 1e6,
              rc ? ": " : "", rc ? strerror(-rc) : "");
}

static void run_triggers(struct run *r)
{
    for (uint32_t f = 0; f < r->table.focus_count && f < 4; f++) {
        static char names[4][32], cmds[4][32];
        haptic_focus_info info;
        haptic_table_focus(&r->table, f, &info);
        snprintf(names[f], sizeof names[f], "trigger focus %u", info.id);
        snprintf(cmds[f], sizeof cmds[f], "focus %u", info.id);
        trigger(r, names[f], cmds[f], 1, f, 0);
    }
    haptic_focus_info f1, f2;
    haptic_table_focus(&r->table, 1, &f1);
    haptic_table_focus(&r->table, 2, &f2);
    static char both[32];
    snprintf(both, sizeof both, "foci %u,%u", f1.id, f2.id);
    trigger(r, "two foci at once", both, 2, 1, 2);

    /* The reader stops for longer than the capture buffer: the capture side
     * overruns, recovers, and the next voice is recorded intact. */
    unsigned overruns = atomic_load(&r->cap.overruns);
    atomic_store(&r->cap.stall_ms, 400);
    sleep_ms(600);
    vb_result(atomic_load(&r->cap.overruns) > overruns, "capture overrun",
              "reader stopped 400 ms (capture buffer %.0f ms): %u overrun(s), recording restarted",
              1e3 * (double)r->cap.buffer_frames / r->cap.rate_hz, atomic_load(&r->cap.overruns) - overruns);
    trigger(r, "trigger after the capture overrun", "focus 3", 1, 3, 0);

    /* hapticd stopped 10 ms into a voice for longer than its buffer: the
     * playback side underruns; hapticd recovers (the buffer primed with
     * silence), the voice goes on after that silence, and the next trigger
     * plays intact. */
    trigger_then(r, "voice across a playback underrun", "focus 2", 1, 2, 0, 10);
    kill(r->pid, SIGSTOP);
    sleep_ms(150);
    kill(r->pid, SIGCONT);
    sleep_ms(400);
    trigger(r, "trigger after the playback underrun", "focus 0", 1, 0, 0);
}

static void run_touches(struct run *r)
{
    for (uint32_t f = 0; f < r->table.focus_count && f < 4; f++) {
        static char names[4][32];
        int x, y;
        focus_on_panel(&r->table, f, &x, &y);
        snprintf(names[f], sizeof names[f], "touch on focus %u", f);
        touch(r, names[f], 1, &x, &y, f, 0);
    }
    int x[2], y[2];
    focus_on_panel(&r->table, 0, &x[0], &y[0]);
    focus_on_panel(&r->table, 3, &x[1], &y[1]);
    touch(r, "two contacts at once", 2, x, y, 0, 3);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Trigger (the FIFO write, or the kernel's stamp of a touch) to the tick at
 * which snd-aloop handed the voice's first frame to the capture side. With
 * the trigger rewound into the queue that is the next tick or so; queued
 * behind the buffer it would be about the buffer time. Emulation stalls the
 * whole guest now and then (an unprovoked xrun shows it), so the median
 * judges, with a tick of slack for a loaded host, and every voice must be
 * causal. */
static void report_latency(const struct run *r, double buffer_s, const char *name, unsigned from, unsigned to)
{
    double lat[MAX_EXPECT];
    unsigned n = 0;
    for (unsigned i = from; i < to; i++)
        if (r->expect[i].found)
            lat[n++] = r->expect[i].latency_s;
    if (!n)
        return;
    qsort(lat, n, sizeof lat[0], cmp_double);
    double median = n % 2 ? lat[n / 2] : (lat[n / 2 - 1] + lat[n / 2]) / 2;
    double tick_s = r->tick_hz ? 1.0 / r->tick_hz : 0.004;
    /* Causal within one tick: the capture's timeline assumes evenly spaced
     * ticks, and under emulation a tick comes late now and then. */
    int ok = lat[0] > -tick_s && median < 2 * tick_s + 1e-3;
    vb_result(ok, name,
              "trigger to first frame on the capture over %u voices: min %.2f ms, "
              "median %.2f ms, max %.2f ms (timer tick %.1f ms, hapticd's buffer %.2f ms)",
              n, lat[0] * 1e3, median * 1e3, lat[n - 1] * 1e3, tick_s * 1e3, buffer_s * 1e3);
}

static long report_value(const char *key)
{
    const char *text = read_text(LATENCY_PATH), *p = text ? strstr(text, key) : NULL;
    return p ? strtol(p + strlen(key), NULL, 10) : -1;
}

/* The board's [alsa] device (what hapticd names in its messages). */
static const char *board_device(const char *board)
{
    static char dev[128];
    const char *text = read_text(board), *p = text ? strstr(text, "\ndevice = ") : NULL;
    if (!p || sscanf(p, "\ndevice = %127s", dev) != 1)
        snprintf(dev, sizeof dev, "hw:Loopback,0,0");
    return dev;
}

/* The loopback card's platform device and its driver's unbind file, found
 * through sysfs (/proc/asound/Loopback -> cardN -> its device and driver). */
static int loopback_unbind_path(char *device, size_t device_cap, char *unbind, size_t unbind_cap, int *card)
{
    char link[PATH_MAX], path[PATH_MAX], drv[PATH_MAX];
    ssize_t n = readlink("/proc/asound/Loopback", link, sizeof link - 1);
    if (n <= 0)
        return -errno;
    link[n] = '\0';
    if (sscanf(link, "card%d", card) != 1)
        return -ENOENT;
    snprintf(path, sizeof path, "/sys/class/sound/card%d/device", *card);
    if (!realpath(path, link))
        return -errno;
    snprintf(device, device_cap, "%s", basename(link));
    snprintf(path, sizeof path, "/sys/class/sound/card%d/device/driver", *card);
    if (!realpath(path, drv))
        return -errno;
    if ((size_t)snprintf(unbind, unbind_cap, "%s/unbind", drv) >= unbind_cap)
        return -ENAMETOOLONG;
    return 0;
}

/* Writes `device` to `unbind` in a child: the kernel disconnects the card at
 * once, then waits in the write until every file on it is closed (hapticd's
 * included). The child's exit status is 0 or the write's errno. */
static pid_t unbind_async(const char *unbind, const char *device)
{
    pid_t pid = fork();
    if (pid == 0) {
        int fd = open(unbind, O_WRONLY);
        if (fd < 0)
            _exit(errno & 0xff);
        ssize_t len = (ssize_t)strlen(device);
        _exit(write(fd, device, (size_t)len) == len ? 0 : errno & 0xff);
    }
    return pid;
}

/* Waits for pid until deadline_ns (CLOCK_MONOTONIC); returns 1 with *status
 * and *at_ns once it exited, 0 at the deadline. Sends `trigger` to hapticd's
 * FIFO every 100 ms meanwhile, if given (a write error is no concern: the
 * reader may be gone). */
static int wait_until(pid_t pid, uint64_t deadline_ns, int *status, uint64_t *at_ns, int fifo, const char *trigger)
{
    uint64_t next_trigger = vb_now_ns();
    for (;;) {
        if (waitpid(pid, status, WNOHANG) == pid) {
            *at_ns = vb_now_ns();
            return 1;
        }
        uint64_t now = vb_now_ns();
        if (now >= deadline_ns)
            return 0;
        if (trigger && fifo >= 0 && now >= next_trigger) {
            if (write(fifo, trigger, strlen(trigger)) < 0) {
                /* EPIPE once hapticd is gone (SIGPIPE ignored) */
            }
            next_trigger = now + 100000000u;
        }
        sleep_ms(10);
    }
}

/* A failing device through the real kernel driver: hapticd plays, triggers
 * going, and the loopback card is removed under it (its platform device
 * unbound from snd_aloop: what a USB card unplugged or a driver unloaded does
 * to an open PCM). Every write then fails (the substream is disconnected);
 * hapticd gives up after HD_AUDIO_GIVE_UP_NS (3 s) of errors and exits 1.
 * The bound is guest time from the unbind: 3 s of errors, the main thread's
 * 200 ms poll and the stop, with room for emulation's stalls (tens of ms; a
 * stall over a second would restart hapticd's failing stretch once). */
#define FAILING_BOUND_S 10
static void check_failing_device(struct run *r)
{
    const char *name = "failing device";
    char device[128], unbind[PATH_MAX];
    int card = -1;
    int rc = loopback_unbind_path(device, sizeof device, unbind, sizeof unbind, &card);
    if (rc) {
        vb_result(0, name, "finding the loopback card's platform device in sysfs: %s", strerror(-rc));
        return;
    }
    if (r->fifo >= 0)
        close(r->fifo); /* the first run's FIFO */
    r->fifo = -1;
    r->log = FAILING_LOG_PATH;
    if ((rc = start_hapticd(r, FAILING_OUT_PATH)) != 0) {
        vb_result(0, name, "hapticd did not start again on %s: %s", r->board, strerror(-rc));
        printf("hapticd log (failing device):\n%s", read_text(r->log) ? read_text(r->log) : "");
        stop_hapticd(r);
        return;
    }
    static const char trigger_line[] = "focus 0\n";
    for (int i = 0; i < 3; i++) { /* playing: a voice sounds when the card goes */
        if (write(r->fifo, trigger_line, sizeof trigger_line - 1) < 0) {
            /* judged below: hapticd's exit says what happened */
        }
        sleep_ms(i < 2 ? 100 : 10);
    }
    int status = 0;
    uint64_t t_unbind = vb_now_ns(), t_exit = 0, t_unbound = 0;
    pid_t child = unbind_async(unbind, device);
    if (child < 0) {
        vb_result(0, name, "fork: %s", strerror(errno));
        stop_hapticd(r);
        return;
    }
    int exited =
        wait_until(r->pid, t_unbind + FAILING_BOUND_S * 1000000000ull, &status, &t_exit, r->fifo, trigger_line);
    if (!exited) { /* hung: end it so that the card's removal can finish */
        kill(r->pid, SIGKILL);
        waitpid(r->pid, NULL, 0);
    }
    r->pid = 0;
    close(r->fifo);
    r->fifo = -1;
    int unbind_status = 0;
    int unbound = wait_until(child, vb_now_ns() + 10000000000ull, &unbind_status, &t_unbound, -1, NULL);
    char card_dir[64];
    snprintf(card_dir, sizeof card_dir, "/sys/class/sound/card%d", card);
    int card_gone = access(card_dir, F_OK) != 0;

    /* hapticd's stderr: the give-up line names the device; libasound's own
     * messages come through hapticd's log ("libasound: "), never raw. */
    const char *dev = board_device(r->board);
    char want[256];
    snprintf(want, sizeof want, "ALSA device '%s' failed", dev);
    const char *text = read_text(r->log);
    char gave_up[512] = "";
    unsigned raw_lib = 0;
    for (const char *line = text; line && *line;) {
        const char *end = strchr(line, '\n');
        size_t len = end ? (size_t)(end - line) : strlen(line);
        if (!strncmp(line, "ALSA lib ", 9))
            raw_lib++;
        char buf[512];
        snprintf(buf, sizeof buf, "%.*s", (int)(len < sizeof buf ? len : sizeof buf - 1), line);
        if (!gave_up[0] && strstr(buf, "giving up"))
            snprintf(gave_up, sizeof gave_up, "%s", buf);
        line = end ? end + 1 : line + len;
    }
    int named = gave_up[0] && strstr(gave_up, want);
    int exit1 = exited && WIFEXITED(status) && WEXITSTATUS(status) == 1;
    const double exit_s = (double)(t_exit - t_unbind) / 1e9;
    char how[96];
    if (!exited)
        snprintf(how, sizeof how, "still running after %d s (hung; killed)", FAILING_BOUND_S);
    else if (WIFSIGNALED(status))
        snprintf(how, sizeof how, "killed by signal %d (%s) after %.2f s", WTERMSIG(status),
                 strsignal(WTERMSIG(status)), exit_s);
    else
        snprintf(how, sizeof how, "exit status %d after %.2f s", WEXITSTATUS(status), exit_s);
    char unbound_how[96];
    if (!unbound)
        snprintf(unbound_how, sizeof unbound_how, "the unbind write still blocked 10 s later");
    else if (!WIFEXITED(unbind_status) || WEXITSTATUS(unbind_status))
        snprintf(unbound_how, sizeof unbound_how, "the unbind write failed: %s",
                 WIFEXITED(unbind_status) ? strerror(WEXITSTATUS(unbind_status)) : "child killed");
    else
        snprintf(unbound_how, sizeof unbound_how, "unbind returned after %.2f s, card%d %s",
                 (double)(t_unbound - t_unbind) / 1e9, card, card_gone ? "gone" : "still present");
    char said[600];
    if (named)
        snprintf(said, sizeof said, "stderr \"%s\"", gave_up);
    else if (gave_up[0])
        snprintf(said, sizeof said, "stderr's give-up line does not name '%s': \"%s\"", dev, gave_up);
    else
        snprintf(said, sizeof said, "stderr has no \"giving up\" line");
    int ok =
        exit1 && named && !raw_lib && unbound && WIFEXITED(unbind_status) && !WEXITSTATUS(unbind_status) && card_gone;
    vb_result(ok, name,
              "%s unbound from %s while hapticd played with triggers going: hapticd %s (bound %d s, exit 1 wanted); "
              "%s; %s; %u raw \"ALSA lib \" line(s)",
              device, unbind, how, FAILING_BOUND_S, unbound_how, said, raw_lib);
    printf("hapticd log (failing device):\n%s", text ? text : "");
}

/* The exciters' ratings through the real driver: hapticd again, on the
 * board with [exciters] and [amplifier] ratings that a storm of triggers
 * would exceed STORM_OVER times over unprotected, while the capture records
 * what reached the exciters. The heat of every channel is computed here from
 * the recorded samples, with the first-order model of firmware/src/protect.h
 * written out independently (per sample: heat = a heat + (1 - a) power, a =
 * exp(-1 / (tau rate))); it must stay within the rating, every trigger must
 * be counted, and the protection must have acted. */
#define STORM_BOARD_PATH "/tmp/vboard-storm.ini"
#define STORM_LOG_PATH "/tmp/hapticd-storm.log"
#define STORM_TRIGGERS 150
#define STORM_SPACING_MS 10
#define STORM_OVER 4.0
#define STORM_VOLTS 10.0
#define STORM_OHMS 8.0
#define STORM_TAU_S 0.5

static void check_storm(struct run *r)
{
    const char *name = "touch storm within the ratings";
    const haptic_table *t = &r->table;
    const unsigned C = t->channel_count;
    /* Joules per count^2 and sample, and the heat the storm would give
     * unprotected: each trigger a whole voice (uncorrelated foci add in
     * energy), one every STORM_SPACING_MS, focus after focus. */
    const double j = (STORM_VOLTS / 32767.0) * (STORM_VOLTS / 32767.0) / STORM_OHMS / t->sample_rate_hz;
    double unprotected_w = 0;
    for (unsigned c = 0; c < C; c++) {
        double e = 0;
        for (uint32_t f = 0; f < t->focus_count; f++) {
            const int16_t *s = haptic_table_signal(t, f);
            for (uint32_t n = 0; n < t->samples_per_signal; n++)
                e += (double)s[(size_t)n * C + c] * s[(size_t)n * C + c];
        }
        const double w = j * e / t->focus_count / (STORM_SPACING_MS / 1e3);
        if (w > unprotected_w)
            unprotected_w = w;
    }
    const double rating_w = unprotected_w / STORM_OVER;
    const char *base = read_text(r->board);
    FILE *b = fopen(STORM_BOARD_PATH, "w");
    if (!base || !b) {
        vb_result(0, name, "writing %s: %s", STORM_BOARD_PATH, strerror(errno));
        if (b)
            fclose(b);
        return;
    }
    fprintf(b,
            "%s\n[exciters]\nrated_power_w = %.6f\nimpedance_ohm = %.1f\nthermal_tau_s = %.2f\n"
            "[amplifier]\nfull_scale_v = %.1f\n",
            base, rating_w, STORM_OHMS, STORM_TAU_S, STORM_VOLTS);
    fclose(b);

    if (r->fifo >= 0)
        close(r->fifo); /* the first run's FIFO */
    r->fifo = -1;
    const char *board = r->board;
    r->board = STORM_BOARD_PATH;
    r->log = STORM_LOG_PATH;
    int rc = start_hapticd(r, NULL);
    r->board = board;
    if (rc) {
        vb_result(0, name, "hapticd did not start on %s: %s", STORM_BOARD_PATH, strerror(-rc));
        printf("hapticd log (storm):\n%s", read_text(r->log) ? read_text(r->log) : "");
        stop_hapticd(r);
        return;
    }
    if ((rc = vb_capture_open(&r->cap, CAPTURE_PCM, C, t->sample_rate_hz, 10.0)) || (rc = vb_capture_start(&r->cap))) {
        vb_result(0, name, "capture %s: %s", CAPTURE_PCM, snd_strerror(rc));
        stop_hapticd(r);
        return;
    }
    sleep_ms(300);
    unsigned sent = 0;
    for (unsigned i = 0; i < STORM_TRIGGERS; i++) {
        haptic_focus_info f;
        haptic_table_focus(t, i % t->focus_count, &f);
        char line[32];
        int n = snprintf(line, sizeof line, "focus %u\n", f.id);
        if (write(r->fifo, line, (size_t)n) == n)
            sent++;
        sleep_ms(STORM_SPACING_MS);
    }
    sleep_ms(500);
    vb_capture_stop(&r->cap);
    int status = stop_hapticd(r);
    close(r->fifo);
    r->fifo = -1;
    const long counted = report_value("triggers "), lowered = report_value("voices_lowered "),
               skipped = report_value("voices_skipped ");

    /* The heat of each channel over the recording (S32: table counts x 2^16). */
    const double a = exp(-1.0 / (STORM_TAU_S * r->cap.rate_hz));
    const size_t frames = atomic_load(&r->cap.count);
    double max_heat_w = 0, played_j = 0;
    for (unsigned c = 0; c < C; c++) {
        double heat = 0;
        for (size_t i = 0; i < frames; i++) {
            const double x = r->cap.frames[i * C + c] / 65536.0;
            heat = a * heat + (1 - a) * x * x * j * r->cap.rate_hz;
            played_j += x * x * j;
            if (heat > max_heat_w)
                max_heat_w = heat;
        }
    }
    const unsigned segments = atomic_load(&r->cap.segment_count);
    /* 1 %: the recorded samples are the device format's, the heat hapticd
     * keeps is of its accumulators (the same to within rounding). */
    int ok = status == 0 && segments == 1 && r->cap.error == 0 && sent == STORM_TRIGGERS && counted == (long)sent &&
             lowered + skipped > 0 && max_heat_w <= rating_w * 1.01 && played_j > 0;
    vb_result(ok, name,
              "%u triggers %d ms apart (%ld counted): %ld voices lowered, %ld skipped; hottest coil %.3f W for a "
              "%.3f W rating (unprotected the storm gives %.3f W); %.3f J reached the exciters; %u capture "
              "segment(s); hapticd exit status %d",
              sent, STORM_SPACING_MS, counted, lowered, skipped, max_heat_w, rating_w, unprotected_w, played_j,
              segments, status);
    if (!ok)
        printf("hapticd log (storm):\n%s", read_text(r->log) ? read_text(r->log) : "");
    vb_capture_close(&r->cap);
}

/* ---- hapticd --measure: the plan played on hw:Loopback,0,0, recorded on
 * hw:Loopback,1,0 (its loop), linked ---- */

#define MEASURE_BOARD_PATH "/tmp/vboard-measure.ini"
#define MEASURE_LOG_PATH "/tmp/hapticd-measure.log"
#define MEASURE_PLAN_PATH "/tmp/vboard-plan.wav"
#define MEASURE_REC_PATH "/tmp/vboard-rec.wav"
#define MEASURE_FRAMES 48000u /* 1 s */
#define MEASURE_RUNS 3

static void put_le(uint8_t *p, uint32_t v, int bytes)
{
    for (int i = 0; i < bytes; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

/* Impulse of exciter k: 20000 + k at frame 1001 + 5003 k, over +-40 counts of noise. */
static uint32_t measure_impulse_at(unsigned k) { return 1001u + 5003u * k; }

static int write_plan(const char *path, unsigned channels, int16_t *s)
{
    uint32_t x = 99;
    for (size_t i = 0; i < (size_t)MEASURE_FRAMES * channels; i++) {
        x = x * 1664525u + 1013904223u;
        s[i] = (int16_t)((int)(x >> 24) % 81 - 40);
    }
    for (unsigned k = 0; k < channels; k++)
        s[(size_t)measure_impulse_at(k) * channels + k] = (int16_t)(20000 + k);
    const uint32_t bytes = MEASURE_FRAMES * channels * 2;
    uint8_t h[44];
    memcpy(h, "RIFF", 4);
    put_le(h + 4, 36 + bytes, 4);
    memcpy(h + 8, "WAVEfmt ", 8);
    put_le(h + 16, 16, 4);
    put_le(h + 20, 1, 2);
    put_le(h + 22, channels, 2);
    put_le(h + 24, 48000, 4);
    put_le(h + 28, 48000 * channels * 2, 4);
    put_le(h + 32, channels * 2, 2);
    put_le(h + 34, 16, 2);
    memcpy(h + 36, "data", 4);
    put_le(h + 40, bytes, 4);
    FILE *f = fopen(path, "wb");
    if (!f)
        return -errno;
    int ok = fwrite(h, 1, sizeof h, f) == sizeof h && fwrite(s, 2, (size_t)MEASURE_FRAMES * channels, f) ==
                                                          (size_t)MEASURE_FRAMES * channels; /* little-endian host */
    return fclose(f) == 0 && ok ? 0 : -EIO;
}

/* hapticd --measure on `board`; its exit status (-1: killed at 60 s). */
static int run_measure(struct run *r, const char *board)
{
    char *argv[] = {(char *)r->hapticd, "--board",   (char *)board,    "--measure",
                    MEASURE_PLAN_PATH,  "--capture", MEASURE_REC_PATH, NULL};
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 2, MEASURE_LOG_PATH, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 2, 1);
    pid_t pid;
    int rc = posix_spawn(&pid, r->hapticd, &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc)
        return -1;
    for (int i = 0; i < 1200; i++) {
        int st;
        if (waitpid(pid, &st, WNOHANG) == pid)
            return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        sleep_ms(50);
    }
    kill(pid, SIGKILL);
    waitpid(pid, NULL, 0);
    return -1;
}

/* Each impulse's offset in the recording from its plan frame (the same for
 * all channels when aligned); *exact: the whole recording equals the plan
 * shifted by that offset. Returns the number of channels whose impulse
 * was found with the same offset as channel 0. */
static unsigned measure_offsets(const int16_t *plan, unsigned channels, long *offset, int *exact)
{
    FILE *f = fopen(MEASURE_REC_PATH, "rb");
    static int32_t rec[MEASURE_FRAMES * 8];
    uint8_t h[44];
    *exact = 0;
    if (!f)
        return 0;
    size_t got = fread(h, 1, sizeof h, f) == sizeof h && !memcmp(h + 36, "data", 4)
                     ? fread(rec, 4 * channels, MEASURE_FRAMES, f)
                     : 0;
    fclose(f);
    if (got != MEASURE_FRAMES || channels > 8)
        return 0;
    unsigned same = 0;
    for (unsigned k = 0; k < channels; k++) {
        long best = -1;
        int32_t peak = 0;
        for (size_t n = 0; n < MEASURE_FRAMES; n++)
            if (abs(rec[n * channels + k] / 65536) > peak) {
                peak = abs(rec[n * channels + k] / 65536);
                best = (long)n;
            }
        long off = best - (long)measure_impulse_at(k);
        if (k == 0)
            *offset = off;
        same += off == *offset && peak == (int32_t)(20000 + k);
    }
    *exact = 1;
    for (size_t n = 0; n < MEASURE_FRAMES; n++)
        for (unsigned k = 0; k < channels; k++) {
            long j = (long)n - *offset;
            int32_t want = j >= 0 && j < (long)MEASURE_FRAMES ? plan[(size_t)j * channels + k] * 65536 : 0;
            if (rec[n * channels + k] != want)
                *exact = 0;
        }
    return same;
}

static void check_measure(struct run *r)
{
    const char *name = "measure aligned";
    const unsigned C = r->table.channel_count;
    const char *base = read_text(r->board);
    FILE *b = fopen(MEASURE_BOARD_PATH, "w");
    if (!base || !b || C > 8) {
        vb_result(0, name, "writing %s: %s", MEASURE_BOARD_PATH, strerror(errno));
        if (b)
            fclose(b);
        return;
    }
    fprintf(b, "%s\n[capture]\ndevice = %s\nchannels = %u\nformat = S32_LE\nrate_hz = 48000\n", base, CAPTURE_PCM, C);
    fclose(b);
    static int16_t plan[MEASURE_FRAMES * 8];
    if (write_plan(MEASURE_PLAN_PATH, C, plan) != 0) {
        vb_result(0, name, "writing %s", MEASURE_PLAN_PATH);
        return;
    }
    char offsets[256] = "";
    int all_ok = 1, all_exact = 1;
    long first = 0;
    for (int run = 0; run < MEASURE_RUNS; run++) {
        unlink(MEASURE_REC_PATH);
        int st = run_measure(r, MEASURE_BOARD_PATH);
        long off = 0;
        int exact = 0;
        unsigned same = st == 0 ? measure_offsets(plan, C, &off, &exact) : 0;
        if (run == 0)
            first = off;
        if (st != 0 || same != C) {
            all_ok = 0;
            printf("hapticd --measure (run %d, exit %d):\n%s", run, st, read_text(MEASURE_LOG_PATH));
        }
        all_exact &= exact;
        size_t n = strlen(offsets);
        snprintf(offsets + n, sizeof offsets - n, "%s%ld%s", run ? ", " : "", off, exact ? "" : " (not exact)");
        if (off != first)
            all_ok = 0;
    }
    printf("hapticd --measure log (last run):\n%s", read_text(MEASURE_LOG_PATH) ? read_text(MEASURE_LOG_PATH) : "");
    vb_result(all_ok && first == 0 && all_exact, name,
              "%d runs, linked playback/capture on snd-aloop: each exciter's impulse at its plan frame %s; offsets "
              "(recording - plan, frames) %s; whole recording equal to the plan: %s",
              MEASURE_RUNS, all_ok && first == 0 ? "exactly" : "NOT exactly", offsets, all_exact ? "yes" : "no");

    /* The capture device busy (this driver holds it): one hapticd line, nothing written. */
    snd_pcm_t *busy;
    int rc = snd_pcm_open(&busy, CAPTURE_PCM, SND_PCM_STREAM_CAPTURE, SND_PCM_NONBLOCK);
    if (rc < 0) {
        vb_result(0, "measure capture busy", "opening %s: %s", CAPTURE_PCM, snd_strerror(rc));
        return;
    }
    unlink(MEASURE_REC_PATH);
    int st = run_measure(r, MEASURE_BOARD_PATH);
    snd_pcm_close(busy);
    const char *text = read_text(MEASURE_LOG_PATH);
    unsigned lines = 0;
    for (const char *p = text; p && *p; p++)
        lines += *p == '\n';
    const int ok = st == 1 && text && strstr(text, "busy") && lines == 1 && !strstr(text, "ALSA lib") &&
                   access(MEASURE_REC_PATH, F_OK) != 0;
    vb_result(ok, "measure capture busy", "exit %d, %u line(s): %s", st, lines, text ? text : "");
}

static int run(struct run *r)
{
    haptic_table_error err;
    if (haptic_table_open(r->table_path, &r->table, &err) != 0) {
        vb_result(0, "table", "%s: %s", r->table_path, err.message);
        return 1;
    }
    r->panel.uinput_fd = r->panel.evdev_fd = -1;
    check_uinput(r); /* before hapticd, so a board that names the panel finds it */
    r->log = LOG_PATH;
    int rc = start_hapticd(r, NULL);
    vb_result(rc == 0, "hapticd starts", "on %s: %s", r->board, rc ? strerror(-rc) : "running");
    if (rc) {
        printf("%s", read_text(r->log) ? read_text(r->log) : "");
        return 1;
    }
    vb_result(log_has(r, "triggers start at once"), "rewind", "snd-aloop rewinds queued frames (hapticd: %s)",
              log_has(r, "triggers start at once") ? "triggers start at once" : "cannot rewind");
    if ((rc = vb_capture_open(&r->cap, CAPTURE_PCM, r->table.channel_count, r->table.sample_rate_hz, 20.0)) ||
        (rc = vb_capture_start(&r->cap))) {
        vb_result(0, "capture", "%s: %s", CAPTURE_PCM, snd_strerror(rc));
        stop_hapticd(r);
        return 1;
    }
    r->cap.tick_hz = r->tick_hz;
    sleep_ms(300); /* a few timer ticks for the capture clock's estimate */
    run_triggers(r);
    r->touch_first = r->expect_count;
    if (r->touch && r->panel.uinput_fd >= 0)
        run_touches(r);
    sleep_ms(200);
    vb_capture_stop(&r->cap);
    int status = stop_hapticd(r);
    vb_result(status == 0, "hapticd stops", "SIGTERM: exit status %d", status);
    /* hapticd's buffer: period x periods of the board, as granted (logged). */
    double buffer_s = 0;
    const char *text = read_text(r->log), *p = text ? strstr(text, "frames = ") : NULL;
    if (p)
        buffer_s = strtod(p + 9, NULL) / 1e3;
    vb_result(log_has(r, "xrun recovered"), "playback underrun",
              "hapticd stopped 150 ms (buffer %.1f ms): %s; %ld xrun(s) in all, %ld trigger(s) rewound in",
              buffer_s * 1e3, log_has(r, "xrun recovered") ? "xrun recovered" : "no xrun reported",
              report_value("xruns "), report_value("rewinds "));
    vb_result(r->cap.error == 0, "capture", "%zu frames recorded, %u segment(s)%s%s", atomic_load(&r->cap.count),
              atomic_load(&r->cap.segment_count), r->cap.error ? ": " : "",
              r->cap.error ? snd_strerror(r->cap.error) : "");
    for (unsigned i = 0; i < r->expect_count; i++)
        vb_check_voice(&r->cap, &r->table, &r->expect[i], i + 1 < r->expect_count ? r->expect[i + 1].t_ns : 0,
                       (size_t)(buffer_s * r->cap.rate_hz));
    report_latency(r, buffer_s > 0 ? buffer_s : 0.1, "onset latency", 0, r->touch_first);
    if (r->touch_first < r->expect_count) /* from the kernel's stamp of the input frame */
        report_latency(r, buffer_s > 0 ? buffer_s : 0.1, "touch onset latency", r->touch_first, r->expect_count);
    const char *lat = read_text(LATENCY_PATH);
    if (lat)
        printf("hapticd latency report:\n%s", lat);
    printf("hapticd log:\n%s", read_text(r->log) ? read_text(r->log) : "");
    vb_capture_close(&r->cap); /* the card cannot go while we hold it open */
    check_storm(r);
    check_measure(r);
    check_failing_device(r); /* last: the card is gone after it */
    vb_touch_close(&r->panel);
    haptic_table_close(&r->table);
    return vb_failed() ? 1 : 0;
}

int main(int argc, char **argv)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    signal(SIGPIPE, SIG_IGN); /* a trigger written after hapticd left: EPIPE, not death */
    if (argc == 3 && !strcmp(argv[1], "make-table"))
        return vb_make_table(argv[2]) ? 1 : 0;
    if (argc < 2 || strcmp(argv[1], "run")) {
        fprintf(stderr, "usage: vboard-driver make-table OUT.htab\n"
                        "       vboard-driver run --hapticd EXE --board INI --table HTAB [--tick-hz HZ] [--touch]\n");
        return 2;
    }
    static struct run r;
    static const struct option opts[] = {{"hapticd", required_argument, 0, 'h'}, {"board", required_argument, 0, 'b'},
                                         {"table", required_argument, 0, 't'},   {"touch", no_argument, 0, 'T'},
                                         {"tick-hz", required_argument, 0, 'z'}, {0, 0, 0, 0}};
    int c;
    optind = 2;
    while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        switch (c) {
        case 'h':
            r.hapticd = optarg;
            break;
        case 'b':
            r.board = optarg;
            break;
        case 't':
            r.table_path = optarg;
            break;
        case 'T':
            r.touch = 1;
            break;
        case 'z':
            r.tick_hz = (unsigned)strtoul(optarg, NULL, 10);
            break;
        default:
            return 2;
        }
    }
    if (!r.hapticd || !r.board || !r.table_path) {
        fprintf(stderr, "vboard-driver run: --hapticd, --board and --table are required\n");
        return 2;
    }
    return run(&r);
}
