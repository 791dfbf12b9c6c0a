/* ALSA shim with -Wl,--wrap mocks: -EPIPE -> recover -> re-prime -> the period
 * is written; -ESTRPIPE likewise; a failed recovery is reported, not fatal;
 * partial writes; an open failure names the device and the board file. */
#define _DEFAULT_SOURCE
#include "audio_alsa.h"

#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#define MAXCALLS 32
struct call {
    char what;                 /* 'w' writei, 'r' recover, 's' start */
    const void *buf;
    long frames_or_err;
};
static struct call calls[MAXCALLS];
static int ncalls;
static long write_script[MAXCALLS]; /* results of successive writei calls; 0 = accept all */
static int nwrites;
static int recover_result;

snd_pcm_sframes_t __wrap_snd_pcm_writei(snd_pcm_t *pcm, const void *buf, snd_pcm_uframes_t size)
{
    (void)pcm;
    assert_true(ncalls < MAXCALLS);
    calls[ncalls++] = (struct call){'w', buf, (long)size};
    long r = write_script[nwrites++];
    return r == 0 ? (snd_pcm_sframes_t)size : r;
}
int __wrap_snd_pcm_recover(snd_pcm_t *pcm, int err, int silent)
{
    (void)pcm;
    assert_int_equal(silent, 1); /* the RT path never prints */
    calls[ncalls++] = (struct call){'r', NULL, err};
    return recover_result;
}
int __wrap_snd_pcm_start(snd_pcm_t *pcm)
{
    (void)pcm;
    calls[ncalls++] = (struct call){'s', NULL, 0};
    return -EBADFD; /* already running (start threshold reached): fine */
}
int __wrap_snd_pcm_open(snd_pcm_t **pcm, const char *name, snd_pcm_stream_t stream, int mode)
{
    (void)pcm, (void)name, (void)stream, (void)mode;
    return -ENOENT;
}

static struct hd_audio fake(void)
{
    struct hd_audio a;
    memset(&a, 0, sizeof a);
    a.pcm = (snd_pcm_t *)&a; /* never dereferenced by the mocks */
    a.channels = 2;
    a.rate_hz = 48000;
    a.period_frames = 4;
    a.buffer_frames = 8;
    a.frame_bytes = 2 * sizeof(int32_t);
    a.silence = calloc(a.period_frames, a.frame_bytes);
    return a;
}

static int reset(void **state)
{
    (void)state;
    memset(calls, 0, sizeof calls);
    memset(write_script, 0, sizeof write_script);
    ncalls = nwrites = 0;
    recover_result = 0;
    return 0;
}

static void xrun_recovers_and_reprimes(void **state)
{
    (void)state;
    struct hd_audio a = fake();
    int32_t data[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    write_script[0] = -EPIPE;
    assert_int_equal(hd_audio_write(&a, data, 4), 0);
    /* writei(data) -EPIPE, recover(-EPIPE), two silent periods fill the buffer, start, writei(data). */
    assert_int_equal(ncalls, 6);
    assert_int_equal(calls[0].what, 'w');
    assert_ptr_equal(calls[0].buf, data);
    assert_int_equal(calls[1].what, 'r');
    assert_int_equal(calls[1].frames_or_err, -EPIPE);
    assert_int_equal(calls[2].what, 'w');
    assert_ptr_equal(calls[2].buf, a.silence);
    assert_int_equal(calls[3].what, 'w');
    assert_ptr_equal(calls[3].buf, a.silence);
    assert_int_equal(calls[2].frames_or_err + calls[3].frames_or_err, 8);
    assert_int_equal(calls[4].what, 's');
    assert_int_equal(calls[5].what, 'w');
    assert_ptr_equal(calls[5].buf, data);
    assert_int_equal(calls[5].frames_or_err, 4);
    assert_int_equal(a.xruns, 1);
    assert_int_equal(a.errors, 0);
    free(a.silence);
}

static void suspend_recovers(void **state)
{
    (void)state;
    struct hd_audio a = fake();
    int32_t data[8] = {0};
    write_script[0] = -ESTRPIPE;
    assert_int_equal(hd_audio_write(&a, data, 4), 0);
    assert_int_equal(calls[1].what, 'r');
    assert_int_equal(calls[1].frames_or_err, -ESTRPIPE);
    assert_ptr_equal(calls[ncalls - 1].buf, data);
    assert_int_equal(a.suspends, 1);
    assert_int_equal(a.xruns, 0);
    free(a.silence);
}

static void failed_recovery_is_reported(void **state)
{
    (void)state;
    struct hd_audio a = fake();
    int32_t data[8] = {0};
    write_script[0] = -EPIPE;
    recover_result = -ENODEV;
    assert_int_equal(hd_audio_write(&a, data, 4), -ENODEV);
    assert_int_equal(a.errors, 1);
    /* The next period is attempted normally (never fatal). */
    reset(NULL);
    assert_int_equal(hd_audio_write(&a, data, 4), 0);
    free(a.silence);
}

static void other_errors_and_partial_writes(void **state)
{
    (void)state;
    struct hd_audio a = fake();
    int32_t data[8] = {0};
    write_script[0] = 3; /* partial: the rest follows from the right place */
    write_script[1] = 0;
    assert_int_equal(hd_audio_write(&a, data, 4), 0);
    assert_int_equal(ncalls, 2);
    assert_ptr_equal(calls[1].buf, (const char *)data + 3 * a.frame_bytes);
    assert_int_equal(calls[1].frames_or_err, 1);
    reset(NULL);
    write_script[0] = -EIO;
    assert_int_equal(hd_audio_write(&a, data, 4), -EIO);
    assert_int_equal(a.errors, 1);
    /* Endless xruns: bounded retries, then an error (the caller backs off). */
    reset(NULL);
    for (int i = 0; i < MAXCALLS; i++)
        write_script[i] = -EPIPE;
    assert_int_equal(hd_audio_write(&a, data, 4), -EIO);
    free(a.silence);
}

static void open_failure_names_device_and_board(void **state)
{
    (void)state;
    struct hd_board b;
    hd_board_defaults(&b);
    strcpy(b.path, "boards/usb-8ch/board.ini");
    strcpy(b.alsa_device, "hw:CARD=ICUSBAUDIO7D");
    struct hd_audio a;
    char err[HD_ERR_MAX] = "";
    assert_int_equal(hd_audio_open(&a, &b, NULL, err), -ENOENT);
    assert_non_null(strstr(err, "hw:CARD=ICUSBAUDIO7D"));
    assert_non_null(strstr(err, "boards/usb-8ch/board.ini"));
    assert_non_null(strstr(err, "No such file or directory"));
    assert_null(strchr(err, '\n'));
    assert_null(a.pcm);
    assert_int_equal(hd_audio_open(&a, &b, "hw:9", err), -ENOENT);
    assert_non_null(strstr(err, "'hw:9'"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(xrun_recovers_and_reprimes, reset),
        cmocka_unit_test_setup(suspend_recovers, reset),
        cmocka_unit_test_setup(failed_recovery_is_reported, reset),
        cmocka_unit_test_setup(other_errors_and_partial_writes, reset),
        cmocka_unit_test_setup(open_failure_names_device_and_board, reset),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
