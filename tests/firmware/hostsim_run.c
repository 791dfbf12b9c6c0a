/* hostsim_run.c - hostsim_run.h. */
#define _GNU_SOURCE
#include "hostsim_run.h"

#include <fcntl.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <setjmp.h>
#include <stdarg.h>
#include <cmocka.h>

extern char **environ;

char hs_dir[256];

void hs_path(char *out, size_t cap, const char *name)
{
    int n = snprintf(out, cap, "%s/%s", hs_dir, name);
    assert_true(n > 0 && (size_t)n < cap);
}

void hs_files(struct hs_files *f, const char *stem)
{
    char name[64];
    const char *suffix[] = {".htab", "-triggers", ".wav", ".ini", "-stderr.txt", "-report.txt", "-script.txt"};
    char *out[] = {f->table, f->fifo, f->wav, f->board, f->err, f->report, f->script};
    for (int i = 0; i < 7; i++) {
        snprintf(name, sizeof name, "%s%s", stem, suffix[i]);
        hs_path(out[i], sizeof f->table, name); /* every path field has its size */
    }
    snprintf(f->device, sizeof f->device, "hostsim:FILE=\"%s\"", f->wav);
}

pid_t hs_spawn(char *const argv[], const char *stderr_path)
{
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 2, stderr_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_t pid;
    assert_int_equal(posix_spawn(&pid, HAPTICD_EXE, &fa, NULL, argv, environ), 0);
    posix_spawn_file_actions_destroy(&fa);
    return pid;
}

pid_t hs_start_live(const struct hs_files *f, int report, int *fd)
{
    unlink(f->fifo);
    assert_int_equal(mkfifo(f->fifo, 0600), 0);
    char *argv[] = {"hapticd", "--board", (char *)f->board, "--table", (char *)f->table, "--triggers",
                    (char *)f->fifo, "--alsa-device", (char *)f->device, "--latency-report", (char *)f->report, NULL};
    if (!report)
        argv[9] = NULL;
    pid_t pid = hs_spawn(argv, f->err);
    *fd = open(f->fifo, O_WRONLY); /* blocks until hapticd has it open */
    assert_true(*fd >= 0);
    hs_wait_for(f->err, "running");
    return pid;
}

int hs_wait_exit(pid_t pid)
{
    int st;
    assert_int_equal(waitpid(pid, &st, 0), pid);
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

/* A live run must end with status 0; otherwise show what hapticd said
 * (a sanitizer's report is there too). */
void hs_assert_clean_exit(pid_t pid, const char *stderr_path)
{
    int st = hs_wait_exit(pid);
    if (st != 0) {
        char buf[16384];
        FILE *f = fopen(stderr_path, "r");
        size_t n = f ? fread(buf, 1, sizeof buf - 1, f) : 0;
        buf[n] = '\0';
        if (f)
            fclose(f);
        fail_msg("hapticd exited with %d; its stderr:\n%s", st, buf);
    }
}

void hs_write_board_extra(const char *file, const char *format, const char *map, const char *alsa_extra)
{
    FILE *f = fopen(file, "w");
    assert_non_null(f);
    /* The shipped asoundrc, the documented host-sim parameters, a test format/map. */
    fprintf(f, "[alsa]\ndevice = hostsim\nconfig = %.*s/asoundrc\nchannels = 8\nformat = %s\nrate_hz = 48000\n"
               "period_frames = 64\nperiods = 2\nchannel_map = %s\npacing = clock\n%s"
               "[realtime]\npriority = 0\nmlock = false\n",
            (int)(strrchr(HOSTSIM_BOARD, '/') - HOSTSIM_BOARD), HOSTSIM_BOARD, format, map, alsa_extra);
    fclose(f);
}

void hs_write_board(const char *file, const char *format, const char *map)
{
    hs_write_board_extra(file, format, map, "");
}

int32_t *hs_read_wav(const char *file, sf_count_t *frames, int want_format)
{
    SF_INFO info = {0};
    SNDFILE *sf = sf_open(file, SFM_READ, &info);
    if (!sf)
        fail_msg("%s: %s", file, sf_strerror(NULL));
    assert_int_equal(info.channels, HS_CHANNELS);
    assert_int_equal(info.samplerate, 48000);
    assert_int_equal(info.format & SF_FORMAT_SUBMASK, want_format);
    int32_t *buf = calloc((size_t)info.frames * HS_CHANNELS, sizeof *buf);
    assert_int_equal(sf_readf_int(sf, buf, info.frames), info.frames);
    sf_close(sf);
    *frames = info.frames;
    return buf;
}

int hs_file_contains(const char *file, const char *needle)
{
    char buf[8192] = "";
    FILE *f = fopen(file, "r");
    if (!f)
        return 0;
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    buf[n] = '\0';
    fclose(f);
    return strstr(buf, needle) != NULL;
}

void hs_wait_for(const char *file, const char *needle)
{
    for (int i = 0; i < 500; i++) {
        if (hs_file_contains(file, needle))
            return;
        struct timespec ts = {0, 10000000};
        nanosleep(&ts, NULL);
    }
    fail_msg("%s never said '%s'", file, needle);
}

void hs_sleep_ms(long ms)
{
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000};
    nanosleep(&ts, NULL);
}

/* Frames where a voice starts: the first non-zero frame after `from`. */
sf_count_t hs_onset(const int32_t *w, sf_count_t frames, sf_count_t from)
{
    for (sf_count_t n = from; n < frames; n++)
        for (uint32_t c = 0; c < HS_CHANNELS; c++)
            if (w[n * HS_CHANNELS + c])
                return n;
    return -1;
}

long hs_report_value(const char *file, const char *key)
{
    FILE *f = fopen(file, "r");
    assert_non_null(f);
    char line[256];
    long v = -1;
    size_t n = strlen(key);
    while (fgets(line, sizeof line, f))
        if (!strncmp(line, key, n) && line[n] == ' ')
            v = strtol(line + n + 1, NULL, 10);
    fclose(f);
    return v;
}

int hs_setup(void **state)
{
    (void)state;
    const char *tmp = getenv("TMPDIR");
    snprintf(hs_dir, sizeof hs_dir, "%s/hapticd-test-XXXXXX", tmp && *tmp ? tmp : "/tmp");
    assert_non_null(mkdtemp(hs_dir));
    return 0;
}

int hs_teardown(void **state)
{
    (void)state;
    char cmd[400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", hs_dir);
    return system(cmd) == 0 ? 0 : -1;
}

void hs_send_focus(int fd, uint32_t id)
{
    char line[64];
    int n = snprintf(line, sizeof line, "focus %u\n", id);
    assert_int_equal(write(fd, line, (size_t)n), n);
}
