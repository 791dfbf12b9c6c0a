/* hostsim_run.c - hostsim_run.h. */
#define _GNU_SOURCE
#include "hostsim_run.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/ioctl.h>
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

pid_t hs_spawn(char *const argv[], const char *stderr_path) { return hs_spawn_out(argv, NULL, stderr_path); }

pid_t hs_spawn_out(char *const argv[], const char *stdout_path, const char *stderr_path)
{
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    if (stdout_path)
        posix_spawn_file_actions_addopen(&fa, 1, stdout_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
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
    char *argv[] = {"hapticd",         "--board",          (char *)f->board,  "--table",
                    (char *)f->table,  "--triggers",       (char *)f->fifo,   "--alsa-device",
                    (char *)f->device, "--latency-report", (char *)f->report, NULL};
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
        size_t len;
        char *text = hs_slurp(stderr_path, &len);
        fail_msg("hapticd exited with %d; its stderr:\n%s", st, text);
    }
}

void hs_write_board_extra(const char *file, const char *format, const char *map, const char *alsa_extra)
{
    FILE *f = fopen(file, "w");
    assert_non_null(f);
    /* The shipped asoundrc, the documented host-sim parameters, a test format/map. */
    fprintf(f,
            "[alsa]\ndevice = hostsim\nconfig = %.*s/asoundrc\nchannels = 8\nformat = %s\nrate_hz = 48000\n"
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

/* The whole file, or NULL when it cannot be opened (not there yet). */
static char *read_all(const char *file, size_t *len)
{
    FILE *f = fopen(file, "rb");
    if (!f)
        return NULL;
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    assert_non_null(buf);
    for (;;) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap)
            break; /* read to the end (a file still growing: as far as it went) */
        cap *= 2;
        buf = realloc(buf, cap);
        assert_non_null(buf);
    }
    assert_false(ferror(f));
    fclose(f);
    buf[n] = '\0'; /* n < cap */
    *len = n;
    return buf;
}

char *hs_slurp(const char *file, size_t *len)
{
    char *text = read_all(file, len);
    if (!text)
        fail_msg("%s cannot be read", file);
    return text;
}

unsigned hs_count(const char *text, const char *needle)
{
    unsigned k = 0;
    for (const char *p = text; (p = strstr(p, needle)) != NULL; p += strlen(needle))
        k++;
    return k;
}

unsigned hs_file_count(const char *file, const char *needle)
{
    size_t len;
    char *text = read_all(file, &len);
    if (!text)
        return 0;
    unsigned k = hs_count(text, needle);
    free(text);
    return k;
}

int hs_file_contains(const char *file, const char *needle) { return hs_file_count(file, needle) > 0; }

void hs_wait_count(const char *file, const char *needle, unsigned k)
{
    for (int i = 0; i < 1000; i++) {
        if (hs_file_count(file, needle) >= k)
            return;
        hs_sleep_ms(10);
    }
    fail_msg("%s never said '%s' %u times", file, needle, k);
}

void hs_wait_for(const char *file, const char *needle) { hs_wait_count(file, needle, 1); }

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

void hs_wait_fifo_read(int fd)
{
    for (int i = 0; i < 1000; i++) {
        int queued = -1;
        assert_int_equal(ioctl(fd, FIONREAD, &queued), 0);
        if (queued == 0)
            return;
        hs_sleep_ms(10);
    }
    fail_msg("hapticd did not read its trigger FIFO within 10 s");
}

static uint32_t le32(const char *p)
{
    const unsigned char *u = (const unsigned char *)p;
    return u[0] | (uint32_t)u[1] << 8 | (uint32_t)u[2] << 16 | (uint32_t)u[3] << 24;
}

int32_t *hs_wav_snapshot(const char *file, sf_count_t *frames)
{
    *frames = 0;
    size_t len;
    char *raw = read_all(file, &len);
    if (!raw)
        return NULL;
    int32_t *out = NULL;
    if (len >= 12 && !memcmp(raw, "RIFF", 4) && !memcmp(raw + 8, "WAVE", 4)) {
        /* The chunks up to "data"; its size is fixed up only on close. */
        for (size_t at = 12; at + 8 <= len;) {
            const uint32_t size = le32(raw + at + 4);
            if (!memcmp(raw + at, "fmt ", 4) && at + 8 + 16 <= len) {
                assert_int_equal(raw[at + 8 + 2] | raw[at + 8 + 3] << 8, HS_CHANNELS);
                assert_int_equal(raw[at + 8 + 14], 32); /* S32_LE */
            }
            if (!memcmp(raw + at, "data", 4)) {
                const size_t frame_bytes = HS_CHANNELS * sizeof(int32_t);
                *frames = (sf_count_t)((len - at - 8) / frame_bytes);
                out = malloc((size_t)*frames * frame_bytes + 1);
                assert_non_null(out);
                memcpy(out, raw + at + 8, (size_t)*frames * frame_bytes); /* little-endian, as the host */
                break;
            }
            at += 8 + size + (size & 1);
        }
    }
    free(raw);
    if (!*frames) {
        free(out);
        return NULL;
    }
    return out;
}

sf_count_t hs_wait_voice(const char *file, sf_count_t from, sf_count_t length, const struct hs_voice *known,
                         size_t n_known)
{
    for (int i = 0; i < 1000; i++) {
        sf_count_t frames;
        int32_t *w = hs_wav_snapshot(file, &frames);
        sf_count_t onset = -1;
        for (sf_count_t n = from; w && n < frames && onset < 0; n++)
            for (uint32_t c = 0; c < HS_CHANNELS; c++) {
                int64_t y = w[n * HS_CHANNELS + c];
                for (size_t v = 0; v < n_known; v++)
                    if (n >= known[v].at && n - known[v].at < known[v].frames)
                        y -= (int64_t)known[v].samples[(size_t)(n - known[v].at) * HS_CHANNELS + c] * 65536;
                if (y) {
                    onset = n;
                    break;
                }
            }
        free(w);
        if (onset >= 0 && onset + length <= frames)
            return onset;
        hs_sleep_ms(10);
    }
    fail_msg("%s: no new voice of %ld frames from frame %ld within 10 s", file, (long)length, (long)from);
    return -1;
}
