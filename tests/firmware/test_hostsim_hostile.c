/* hapticd on a hostile day, end to end on the host-sim board: the real
 * daemon given odd files, hostile trigger bytes, floods, failing and
 * unpacing devices and early signals. Each case failed before the fix it
 * names: it hung, crashed, let raw bytes into the log, took a setting from a
 * comment, kept running on a dead device or died without a word. */
#define _GNU_SOURCE
#include "fw_fixture.h"
#include "hostsim_run.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#define C 8u

/* Nothing but printable text, tabs and newlines in what hapticd wrote. */
static void assert_log_is_text(const char *text, size_t len)
{
    for (size_t i = 0; i < len; i++) {
        unsigned char c = (unsigned char)text[i];
        if ((c < 0x20 && c != '\n') || c == 0x7f || c >= 0x80)
            fail_msg("raw byte 0x%02x at offset %zu of the log", c, i);
    }
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Waits for the process to end, at most `limit_s`; returns its status as
 * hs_wait_exit does, or fails (after killing it) when it hangs. */
static int wait_exit_within(pid_t pid, double limit_s)
{
    const double end = now_s() + limit_s;
    int st;
    for (;;) {
        pid_t r = waitpid(pid, &st, WNOHANG);
        assert_true(r >= 0);
        if (r == pid)
            return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        if (now_s() > end) {
            kill(pid, SIGKILL);
            waitpid(pid, &st, 0);
            fail_msg("hapticd still running after %.1f s", limit_s);
        }
        hs_sleep_ms(5);
    }
}

static void make_table(struct hs_files *f, const char *stem, struct fw_table *t)
{
    hs_files(f, stem);
    fw_table_make(t, C, 2, 480, FW_RANDOM, 5000, 11);
    fw_table_write(t, f->table);
    hs_write_board(f->board, "S32_LE", "0,1,2,3,4,5,6,7");
}

/* What is sent to the trigger FIFO reaches the log escaped, once per bad
 * line: terminal escapes (a title change, a screen clear), a NUL in a line,
 * a 1 MB line (one warning, not one per 511 bytes), and a flood of bad lines
 * (at most 10 warnings a second and a count of the rest). The good trigger
 * after them plays. */
static void hostile_trigger_bytes_are_escaped_and_counted(void **state)
{
    (void)state;
    struct hs_files f;
    struct fw_table t;
    make_table(&f, "bytes", &t);
    int fd;
    pid_t pid = hs_start_live(&f, 1, &fd);
    static const char esc[] = "\033]0;PWNED\007 \033[2J\n";
    assert_int_equal(write(fd, esc, sizeof esc - 1), (ssize_t)(sizeof esc - 1));
    static const char nul[] = "focus 1\0garbage\n";
    assert_int_equal(write(fd, nul, sizeof nul - 1), (ssize_t)(sizeof nul - 1));
    static char big[1 << 20];
    memset(big, 'z', sizeof big);
    big[sizeof big - 1] = '\n';
    for (size_t at = 0; at < sizeof big;) {
        ssize_t n = write(fd, big + at, sizeof big - at);
        if (n < 0 && errno == EAGAIN) {
            hs_sleep_ms(1);
            continue;
        }
        assert_true(n > 0);
        at += (size_t)n;
    }
    /* The guard's window is wall time (1 s from its first warning, the
     * escape line's): the flood below must fall into a window of its own,
     * so this sleep is the test's subject, not a wait for hapticd. It starts
     * once the last of the three warnings is logged, so it holds on a loaded
     * machine too. */
    hs_wait_for(f.err, "line of 1048575 bytes");
    hs_sleep_ms(1100);
    for (int i = 0; i < 1000; i++) {
        static const char bad[] = "wiggle 3\n";
        assert_int_equal(write(fd, bad, sizeof bad - 1), (ssize_t)(sizeof bad - 1));
    }
    hs_wait_fifo_read(fd);
    hs_send_focus(fd, t.ids[0]);
    hs_wait_voice(f.wav, 0, 480, NULL, 0); /* played: the trigger thread took it */
    kill(pid, SIGTERM);
    hs_assert_clean_exit(pid, f.err);
    close(fd);
    size_t len;
    char *log = hs_slurp(f.err, &len);
    assert_log_is_text(log, len);
    assert_non_null(strstr(log, "unknown command '\\x1b]0;PWNED\\x07'"));
    assert_non_null(strstr(log, ":2: a NUL byte at column 8: not a text line (ignored)"));
    assert_int_equal(hs_count(log, "line of 1048575 bytes, longer than 510"), 1);
    /* At most 10 warnings a window, then a count of the rest: 10 and "990
     * more" when the 1000 lines are read within a second, as they are; a
     * loaded machine may spread them over more windows, each of which then
     * shows at most 10 before its count. */
    unsigned shown = 0, not_shown = 0, summaries = 0;
    for (const char *seg = log;;) {
        const char *end = strstr(seg, " more bad lines not shown");
        unsigned in_window = 0;
        for (const char *p = seg; (p = strstr(p, "unknown command 'wiggle'")) && (!end || p < end); p++)
            in_window++;
        assert_true(in_window <= 10);
        shown += in_window;
        if (!end)
            break;
        const char *q = end;
        while (q > log && q[-1] >= '0' && q[-1] <= '9')
            q--;
        not_shown += (unsigned)strtoul(q, NULL, 10);
        summaries++;
        seg = end + 1;
    }
    assert_true(summaries >= 1);
    assert_int_equal(shown + not_shown, 1000);
    if (summaries == 1)
        assert_non_null(strstr(log, "990 more bad lines not shown"));
    assert_int_equal(hs_report_value(f.report, "triggers"), 1); /* only the good one played */
    free(log);
    fw_table_free(&t);
}

/* A board file whose long comment would have set periods = 32 through inih's
 * cut: refused on its line before anything is opened. */
static void long_board_comment_is_refused(void **state)
{
    (void)state;
    struct hs_files f;
    struct fw_table t;
    make_table(&f, "comment", &t);
    char extra[400];
    int n = snprintf(extra, sizeof extra, "; old setting kept for reference ");
    memset(extra + n, '-', 200);
    snprintf(extra + n + 200, sizeof extra - (size_t)n - 200, " periods = 32\n");
    hs_write_board_extra(f.board, "S32_LE", "0,1,2,3,4,5,6,7", extra);
    char *argv[] = {"hapticd", "--board", f.board, "--table", f.table, "--script", "/dev/null", NULL};
    assert_int_equal(wait_exit_within(hs_spawn(argv, f.err), 10), 1);
    char want[400];
    snprintf(want, sizeof want, "%s:11: line of 246 bytes, longer than 199", f.board);
    assert_true(hs_file_contains(f.err, want));
    fw_table_free(&t);
}

/* hapticd --check on a 2 GiB sparse file that is no table: refused at the
 * magic under a 256 MiB address-space limit (the whole file used to be read
 * first: 2.1 GB resident, 19 s). Skipped under sanitizers, whose shadow
 * memory needs the address space. */
static void check_refuses_a_huge_non_table_without_reading_it(void **state)
{
    (void)state;
#if defined(HAPTIC_ASAN) || defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
    skip(); /* the tsan preset does not set HAPTIC_ASAN: hapticd is built with the same flags as this test */
#else
    char path[400];
    hs_path(path, sizeof path, "sparse.htab");
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    assert_true(fd >= 0);
    assert_int_equal(write(fd, "NOTATABLE", 9), 9);
    assert_int_equal(ftruncate(fd, (off_t)1 << 31), 0);
    close(fd);
    char err[400];
    hs_path(err, sizeof err, "sparse-stderr.txt");
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        struct rlimit rl = {256u << 20, 256u << 20};
        setrlimit(RLIMIT_AS, &rl);
        int efd = open(err, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        dup2(efd, 2);
        execl(HAPTICD_EXE, "hapticd", "--check", path, (char *)NULL);
        _exit(127);
    }
    assert_int_equal(wait_exit_within(pid, 5), 1);
    assert_true(hs_file_contains(err, "offset 0 (magic): not a haptic table"));
    unlink(path);
#endif
}

/* The WAV's folder cannot be written: every write of the file plugin fails.
 * hapticd gives up within seconds with a non-zero status (systemd restarts
 * it), and libasound's hundreds of lines a second come through hapticd's log
 * as a few. */
static void failing_device_ends_the_daemon(void **state)
{
    (void)state;
    struct hs_files f;
    struct fw_table t;
    make_table(&f, "failing", &t);
    char device[500];
    snprintf(device, sizeof device, "hostsim:FILE=\"%s/no/such/folder/out.wav\"", hs_dir);
    unlink(f.fifo);
    assert_int_equal(mkfifo(f.fifo, 0600), 0);
    char *argv[] = {"hapticd",    "--board", f.board,         "--table", f.table,
                    "--triggers", f.fifo,    "--alsa-device", device,    NULL};
    pid_t pid = hs_spawn(argv, f.err);
    assert_int_equal(wait_exit_within(pid, 10), 1);
    size_t len;
    char *log = hs_slurp(f.err, &len);
    assert_log_is_text(log, len);
    assert_non_null(strstr(log, "failed for 3 s without a second's rest: giving up"));
    assert_int_equal(hs_count(log, "ALSA lib "), 0); /* nothing printed by libasound itself */
    assert_true(hs_count(log, "libasound: ") >= 1);
    assert_true(hs_count(log, "libasound: ") <= 2);
    free(log);
    fw_table_free(&t);
}

/* pacing = device on the null PCM (never blocks): detected and refused with
 * the fix in the message, instead of a silent 100 % CPU loop. A PCM that does
 * not exist: one line, libasound's word on it. */
static void unpaced_and_missing_devices_are_named(void **state)
{
    (void)state;
    struct hs_files f;
    struct fw_table t;
    make_table(&f, "null", &t);
    FILE *b = fopen(f.board, "w");
    assert_non_null(b);
    fprintf(b, "[alsa]\ndevice = null\nchannels = 8\nformat = S32_LE\nrate_hz = 48000\nperiod_frames = 64\n"
               "periods = 2\npacing = device\n[realtime]\npriority = 0\nmlock = false\n");
    fclose(b);
    unlink(f.fifo);
    assert_int_equal(mkfifo(f.fifo, 0600), 0);
    char *argv[] = {"hapticd", "--board", f.board, "--table", f.table, "--triggers", f.fifo, NULL};
    assert_int_equal(wait_exit_within(hs_spawn(argv, f.err), 10), 1);
    assert_true(hs_file_contains(f.err, "ALSA device 'null' takes frames faster than real time"));
    assert_true(hs_file_contains(f.err, "needs pacing = clock"));
    char *argv2[] = {"hapticd",    "--board", f.board,         "--table",   f.table,
                     "--triggers", f.fifo,    "--alsa-device", "nosuchpcm", NULL};
    assert_int_equal(wait_exit_within(hs_spawn(argv2, f.err), 10), 1);
    size_t len;
    char *log = hs_slurp(f.err, &len);
    assert_int_equal(hs_count(log, "\n"), 1);
    assert_non_null(strstr(log, "cannot open ALSA device 'nosuchpcm'"));
    assert_non_null(strstr(log, "(libasound: snd_pcm_open_noupdate: Unknown PCM nosuchpcm)"));
    free(log);
    fw_table_free(&t);
}

/* SIGHUP then SIGTERM while hapticd is still loading its table: the reload
 * and the stop are acted on once it runs (the stop drains, exit 0) instead
 * of killing it without a word. The table is large enough to take a while
 * to check; the signals go as soon as the process is in main (its SIGHUP is
 * blocked) or, failing that, 40 ms after the start (before the fix, the
 * signals were blocked only once the threads started). */
static void early_signals_are_not_lost(void **state)
{
    (void)state;
    struct hs_files f;
    hs_files(&f, "early");
    struct fw_table t;
    fw_table_make(&t, C, 16, 200000, FW_RANDOM, 5000, 17); /* 51 MB */
    fw_table_write(&t, f.table);
    fw_table_free(&t);
    hs_write_board(f.board, "S32_LE", "0,1,2,3,4,5,6,7");
    unlink(f.fifo);
    assert_int_equal(mkfifo(f.fifo, 0600), 0);
    char *argv[] = {"hapticd",    "--board", f.board,         "--table", f.table,
                    "--triggers", f.fifo,    "--alsa-device", f.device,  NULL};
    const double t0 = now_s();
    pid_t pid = hs_spawn(argv, f.err);
    char status[64];
    snprintf(status, sizeof status, "/proc/%d/status", (int)pid);
    int blocked = 0;
    /* The signals go in once hapticd has blocked them (its first act), while it
       still loads the 51 MB table: sent before, SIGHUP's default action ends
       it, which no daemon can prevent (an asan build under load took more
       than 40 ms to get there). */
    while (!blocked && now_s() - t0 < 5.0) {
        FILE *s = fopen(status, "r");
        char line[256];
        while (s && fgets(line, sizeof line, s))
            if (!strncmp(line, "SigBlk:", 7))
                blocked = (strtoull(line + 7, NULL, 16) >> (SIGHUP - 1)) & 1;
        if (s)
            fclose(s);
    }
    if (!blocked)
        kill(pid, SIGKILL);
    assert_true(blocked);
    assert_int_equal(kill(pid, SIGHUP), 0);
    assert_int_equal(kill(pid, SIGTERM), 0);
    int st = wait_exit_within(pid, 20);
    if (st != 0)
        fail_msg("hapticd ended with %d after an early SIGHUP/SIGTERM", st);
    assert_false(hs_file_contains(f.err, "running") && !hs_file_contains(f.err, "stopping"));
    assert_true(hs_file_contains(f.err, "stopping (drain)"));
}

/* A touch storm (500 triggers, one every 10 ms, the two foci in turn) on a
 * board whose exciters are rated 0.3 W into 4 ohm, tau 0.5 s, behind a
 * 10 V amplifier: the coils' heat, integrated here from the WAV hapticd
 * wrote (sample by sample, the exponential average of the power), stays
 * within the rating on every channel at every sample, and every trigger is
 * accounted for (played, lowered or skipped). Without [exciters] the same
 * storm heats the coils past it. */
static double storm_worst_heat(const char *wav)
{
    sf_count_t frames;
    int32_t *w = hs_read_wav(wav, &frames, SF_FORMAT_PCM_32);
    const double v = 10.0 / 32767.0, tau = 0.5, decay = exp(-1.0 / (48000.0 * tau));
    double worst = 0;
    for (uint32_t c = 0; c < C; c++) {
        double heat = 0;
        for (sf_count_t n = 0; n < frames; n++) {
            const double x = (double)w[n * C + c] / 65536.0 * v;
            heat = heat * decay + x * x / 4.0 / (48000.0 * tau);
            if (heat > worst)
                worst = heat;
        }
    }
    free(w);
    return worst;
}

static void a_touch_storm_stays_within_the_exciters_ratings(void **state)
{
    (void)state;
    struct hs_files f;
    hs_files(&f, "storm");
    struct fw_table t;
    fw_table_make(&t, C, 2, 2400, FW_RANDOM, 20000, 23);
    fw_table_write(&t, f.table);
    FILE *s = fopen(f.script, "w");
    assert_non_null(s);
    for (int i = 0; i < 500; i++)
        fprintf(s, "at %d focus %u\n", 4800 + 480 * i, t.ids[i % 2]);
    fclose(s);
    const double rated = 0.3;
    for (int protect = 1; protect >= 0; protect--) {
        hs_write_board_extra(f.board, "S32_LE", "0,1,2,3,4,5,6,7",
                             protect ? "[exciters]\nrated_power_w = 0.3\nimpedance_ohm = 4\nthermal_tau_s = 0.5\n"
                                       "[amplifier]\nfull_scale_v = 10\n"
                                     : "");
        char *argv[] = {"hapticd",  "--board", f.board,         "--table", f.table,
                        "--script", f.script,  "--alsa-device", f.device,  NULL};
        assert_int_equal(wait_exit_within(hs_spawn(argv, f.err), 60), 0);
        const double worst = storm_worst_heat(f.wav);
        size_t len;
        char *log = hs_slurp(f.err, &len);
        unsigned long long frames, voices, lowered, skipped;
        const char *done = strstr(log, "script done: ");
        assert_non_null(done);
        assert_int_equal(sscanf(done, "script done: %llu frames written, %llu voices (%llu lowered, %llu skipped",
                                &frames, &voices, &lowered, &skipped),
                         4);
        print_message("storm (%s): heat at most %.4f W (rating %.2f W), %llu voices, %llu lowered, %llu skipped\n",
                      protect ? "protected" : "unprotected", worst, rated, voices, lowered, skipped);
        assert_int_equal(voices + skipped, 500); /* every trigger accounted for */
        if (protect) {
            if (!(worst <= rated))
                fail_msg("protected storm: heat %.4f W over the %.2f W rating", worst, rated);
            assert_true(worst > 0.5 * rated); /* the budget used */
            assert_true(lowered + skipped > 0);
        } else {
            if (!(worst > rated))
                fail_msg("unprotected storm: heat %.4f W within the rating: the storm does not test anything", worst);
            assert_int_equal(lowered + skipped, 0);
        }
        free(log);
    }
    /* Live: a burst of 60 touches is logged once when protection engages and
     * once when the burst is over, with its counts; not once per voice. */
    hs_write_board_extra(f.board, "S32_LE", "0,1,2,3,4,5,6,7",
                         "[exciters]\nrated_power_w = 0.3\nimpedance_ohm = 4\nthermal_tau_s = 0.5\n"
                         "[amplifier]\nfull_scale_v = 10\n");
    int fd;
    pid_t pid = hs_start_live(&f, 0, &fd);
    for (int i = 0; i < 60; i++) {
        hs_send_focus(fd, t.ids[i % 2]);
        hs_sleep_ms(2);
    }
    hs_wait_for(f.err, "burst over");
    kill(pid, SIGTERM);
    hs_assert_clean_exit(pid, f.err);
    close(fd);
    size_t len;
    char *log = hs_slurp(f.err, &len);
    assert_int_equal(hs_count(log, "exciter protection engaged"), 1);
    assert_int_equal(hs_count(log, "exciter protection: burst over"), 1);
    free(log);
    fw_table_free(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(hostile_trigger_bytes_are_escaped_and_counted),
        cmocka_unit_test(long_board_comment_is_refused),
        cmocka_unit_test(check_refuses_a_huge_non_table_without_reading_it),
        cmocka_unit_test(failing_device_ends_the_daemon),
        cmocka_unit_test(unpaced_and_missing_devices_are_named),
        cmocka_unit_test(early_signals_are_not_lost),
        cmocka_unit_test(a_touch_storm_stays_within_the_exciters_ratings),
    };
    return cmocka_run_group_tests(tests, hs_setup, hs_teardown);
}
