/* hapticd --measure on host-sim: the plan plays on hostsim_loop and
 * hostsim_capture reads back what was played (boards/host-sim/asoundrc), a
 * loopback exact to the sample. A plan with one impulse per channel, each at
 * its own frame, over low noise: every impulse is found in the recording at
 * exactly its plan frame, on the ALSA channel the board maps its exciter to,
 * and the whole recording equals the plan (S32 and S16 devices). Every
 * refusal (no [capture], rate, channels, an absent capture device, a plan
 * that is missing, a FIFO or a directory, an unwritable recording path,
 * --measure alone, a plan over the exciters' ratings) is one line, exit 1
 * (2 for usage), and leaves no file where the recording would go. Plans are
 * written and recordings read with libsndfile, not with hapticd's WAV code. */
#define _GNU_SOURCE
#include "hostsim_run.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <sndfile.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#define C 8u
#define FRAMES 24000u

/* The plan: noise of +-40 counts, and on channel k an impulse of 20000 + k
 * at frame impulse_at(k) (off any period or buffer grid). */
static sf_count_t impulse_at(unsigned k) { return 777 + 2731 * (sf_count_t)k; }

static int16_t *make_plan(const char *path, unsigned channels, int rate, sf_count_t frames)
{
    int16_t *s = calloc((size_t)frames * channels, sizeof *s);
    assert_non_null(s);
    uint32_t x = 12345;
    for (size_t i = 0; i < (size_t)frames * channels; i++) {
        x = x * 1664525u + 1013904223u;
        s[i] = (int16_t)((int)(x >> 24) % 81 - 40);
    }
    for (unsigned k = 0; k < channels; k++)
        if (impulse_at(k) < frames)
            s[impulse_at(k) * channels + k] = (int16_t)(20000 + k);
    SF_INFO info = {.samplerate = rate, .channels = (int)channels, .format = SF_FORMAT_WAV | SF_FORMAT_PCM_16};
    SNDFILE *f = sf_open(path, SFM_WRITE, &info);
    assert_non_null(f);
    assert_int_equal(sf_writef_short(f, s, frames), frames);
    sf_close(f);
    return s;
}

struct run {
    char plan[300], rec[300], board[300], err[300], play[700], loop[300];
};

static void paths(struct run *r, const char *stem)
{
    char name[64];
    snprintf(name, sizeof name, "%s-plan.wav", stem);
    hs_path(r->plan, sizeof r->plan, name);
    snprintf(name, sizeof name, "%s-rec.wav", stem);
    hs_path(r->rec, sizeof r->rec, name);
    snprintf(name, sizeof name, "%s.ini", stem);
    hs_path(r->board, sizeof r->board, name);
    snprintf(name, sizeof name, "%s-stderr.txt", stem);
    hs_path(r->err, sizeof r->err, name);
    snprintf(name, sizeof name, "%s-loop.raw", stem);
    hs_path(r->loop, sizeof r->loop, name);
    char wav[300];
    snprintf(name, sizeof name, "%s-played.wav", stem);
    hs_path(wav, sizeof wav, name);
    snprintf(r->play, sizeof r->play, "hostsim_loop:FILE=\"%s\",LOOP=\"%s\"", wav, r->loop);
}

/* The host-sim board (format, map) with a [capture] on the loopback and `extra` after it. */
static void write_board(const struct run *r, const char *format, const char *map, const char *capture_device,
                        const char *extra)
{
    char tail[2048];
    char dev[400];
    if (capture_device)
        snprintf(dev, sizeof dev, "%s", capture_device);
    else
        snprintf(dev, sizeof dev, "hostsim_capture:LOOP=\"%s\"", r->loop);
    snprintf(tail, sizeof tail, "[capture]\ndevice = %s\nplayback_device = %s\nchannels = 8\nformat = %s\n%s", dev,
             r->play, format, extra);
    hs_write_board_extra(r->board, format, map, tail);
}

static int measure(const struct run *r)
{
    char *argv[] = {"hapticd",       "--board",   (char *)r->board, "--measure",
                    (char *)r->plan, "--capture", (char *)r->rec,   NULL};
    return hs_wait_exit(hs_spawn(argv, r->err));
}

static void loopback(const char *format, const char *map_text, const unsigned *map, int sf_format)
{
    struct run r;
    paths(&r, format);
    write_board(&r, format, map_text, NULL, "");
    int16_t *plan = make_plan(r.plan, C, 48000, FRAMES);
    if (measure(&r) != 0) {
        size_t len;
        fail_msg("hapticd --measure failed: %s", hs_slurp(r.err, &len));
    }
    SF_INFO info = {0};
    SNDFILE *f = sf_open(r.rec, SFM_READ, &info);
    assert_non_null(f);
    assert_int_equal(info.channels, C);
    assert_int_equal(info.samplerate, 48000);
    assert_int_equal(info.frames, FRAMES);
    assert_int_equal(info.format & SF_FORMAT_SUBMASK, sf_format);
    int32_t *rec = calloc((size_t)FRAMES * C, sizeof *rec);
    assert_int_equal(sf_readf_int(f, rec, FRAMES), FRAMES);
    sf_close(f);
    /* Each impulse at exactly its plan frame, on its exciter's ALSA channel. */
    for (unsigned k = 0; k < C; k++) {
        sf_count_t best = -1;
        int32_t peak = 0;
        for (sf_count_t n = 0; n < FRAMES; n++)
            if (abs(rec[n * C + map[k]] / 65536) > peak) {
                peak = abs(rec[n * C + map[k]] / 65536);
                best = n;
            }
        if (best != impulse_at(k) || peak != (int32_t)(20000 + k))
            fail_msg("exciter %u (ALSA channel %u): impulse %d at frame %ld, the plan has %u at %ld", k, map[k], peak,
                     (long)best, 20000 + k, (long)impulse_at(k));
    }
    /* And every sample: the recording is the plan. */
    for (sf_count_t n = 0; n < FRAMES; n++)
        for (unsigned k = 0; k < C; k++)
            if (rec[n * C + map[k]] != plan[n * C + k] * 65536)
                fail_msg("frame %ld exciter %u: recorded %d, planned %d", (long)n, k, rec[n * C + map[k]] / 65536,
                         plan[n * C + k]);
    assert_true(hs_file_contains(r.err, "measure: recorded 24000 frames"));
    free(rec);
    free(plan);
}

static void loopback_s32_identity(void **state)
{
    (void)state;
    const unsigned map[C] = {0, 1, 2, 3, 4, 5, 6, 7};
    loopback("S32_LE", "0,1,2,3,4,5,6,7", map, SF_FORMAT_PCM_32);
}

static void loopback_s16_channel_map(void **state)
{
    (void)state;
    const unsigned map[C] = {3, 1, 7, 5, 0, 2, 4, 6};
    loopback("S16_LE", "3,1,7,5,0,2,4,6", map, SF_FORMAT_PCM_16);
}

/* stderr is exactly one line, with `needle`; no temporary or recording left. */
static void assert_refused(const struct run *r, int status, int want_status, const char *needle)
{
    size_t len;
    char *text = hs_slurp(r->err, &len);
    if (status != want_status || !strstr(text, needle) || hs_count(text, "\n") != 1 || strstr(text, "ALSA lib"))
        fail_msg("status %d (want %d), stderr:\n%s(want one line with '%s')", status, want_status, text, needle);
    free(text);
    char name[300];
    snprintf(name, sizeof name, "%s", strrchr(r->rec, '/') + 1);
    DIR *d = opendir(hs_dir);
    for (struct dirent *e; (e = readdir(d));)
        if (!strncmp(e->d_name, name, strlen(name)))
            fail_msg("%s left behind", e->d_name);
    closedir(d);
}

static void refusals(void **state)
{
    (void)state;
    struct run r;
    paths(&r, "refuse");
    free(make_plan(r.plan, C, 48000, 4800));
    /* no [capture] */
    hs_write_board(r.board, "S32_LE", "0,1,2,3,4,5,6,7");
    assert_refused(&r, measure(&r), 1, "no [capture] section");
    /* the plan's rate, its channels */
    write_board(&r, "S32_LE", "0,1,2,3,4,5,6,7", NULL, "");
    free(make_plan(r.plan, C, 44100, 4800));
    assert_refused(&r, measure(&r), 1, "plan at 44100 Hz, the board plays 48000 Hz");
    free(make_plan(r.plan, 4, 48000, 4800));
    assert_refused(&r, measure(&r), 1, "plan of 4 channels, the board drives 8 exciters");
    free(make_plan(r.plan, C, 48000, 4800));
    /* a capture device that does not exist, and one whose loopback file is missing */
    write_board(&r, "S32_LE", "0,1,2,3,4,5,6,7", "nosuchcapture", "");
    assert_refused(&r, measure(&r), 1, "cannot open ALSA capture device 'nosuchcapture' ([capture] device in");
    write_board(&r, "S32_LE", "0,1,2,3,4,5,6,7", "hostsim_capture:LOOP=\"/nonexistent/loop.raw\"", "");
    assert_refused(&r, measure(&r), 1, "cannot open ALSA capture device 'hostsim_capture");
    /* a plan that is missing, a FIFO (never opened blocking: no hang), a directory, not a WAV */
    write_board(&r, "S32_LE", "0,1,2,3,4,5,6,7", NULL, "");
    struct run bad = r;
    hs_path(bad.plan, sizeof bad.plan, "missing.wav");
    assert_refused(&bad, measure(&bad), 1, "missing.wav: cannot open: No such file or directory");
    hs_path(bad.plan, sizeof bad.plan, "plan-fifo");
    assert_int_equal(mkfifo(bad.plan, 0600), 0);
    assert_refused(&bad, measure(&bad), 1, "plan-fifo: not a regular file (a FIFO is no WAV file)");
    snprintf(bad.plan, sizeof bad.plan, "%s", hs_dir);
    assert_refused(&bad, measure(&bad), 1, "not a regular file (a directory is no WAV file)");
    snprintf(bad.plan, sizeof bad.plan, "%s", r.board);
    assert_refused(&bad, measure(&bad), 1, "not a WAV file");
    /* an unwritable recording path: refused before anything plays */
    bad = r;
    hs_path(bad.rec, sizeof bad.rec, "no-such-dir/rec.wav");
    assert_refused(&bad, measure(&bad), 1, "no-such-dir/rec.wav: cannot write the recording there");
    /* --measure alone: usage */
    char *argv[] = {"hapticd", "--board", r.board, "--measure", r.plan, NULL};
    assert_refused(&r, hs_wait_exit(hs_spawn(argv, r.err)), 2, "--measure PLAN.wav and --capture REC.wav go together");
    /* a plan that would heat exciter 5 beyond its rating: full-scale noise on it */
    SF_INFO info = {.samplerate = 48000, .channels = C, .format = SF_FORMAT_WAV | SF_FORMAT_PCM_16};
    int16_t *loud = calloc(48000 * C, sizeof *loud);
    for (size_t n = 0; n < 48000; n++)
        loud[n * C + 5] = (int16_t)(n & 1 ? 30000 : -30000);
    SNDFILE *f = sf_open(r.plan, SFM_WRITE, &info);
    assert_int_equal(sf_writef_short(f, loud, 48000), 48000);
    sf_close(f);
    free(loud);
    write_board(&r, "S32_LE", "0,1,2,3,4,5,6,7", NULL,
                "[exciters]\nrated_power_w = 1\nimpedance_ohm = 8\nthermal_tau_s = 0.5\n[amplifier]\n"
                "full_scale_v = 10\n");
    assert_refused(&r, measure(&r), 1, "exciter 5 would heat to");
    /* A run that fails after the recording's temporary file was made (the
     * capture device cannot open) leaves an earlier recording as it was. */
    write_board(&r, "S32_LE", "0,1,2,3,4,5,6,7", "nosuchcapture", "");
    FILE *old = fopen(r.rec, "w");
    fputs("earlier", old);
    fclose(old);
    assert_int_equal(measure(&r), 1);
    size_t len;
    char *text = hs_slurp(r.rec, &len);
    assert_string_equal(text, "earlier");
    free(text);
    unlink(r.rec);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(loopback_s32_identity),
        cmocka_unit_test(loopback_s16_channel_map),
        cmocka_unit_test(refusals),
    };
    return cmocka_run_group_tests(tests, hs_setup, hs_teardown);
}
