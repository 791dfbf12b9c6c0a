/* ALSA shim with -Wl,--wrap mocks: -EPIPE -> recover -> re-prime -> the period
 * is written; -ESTRPIPE likewise; a failed recovery is reported, not fatal;
 * partial writes; an open failure names the device and the board file.
 * Rewinding a trigger in: the margin and the caller's limit are kept;
 * rewindable 0, negative (transient or not), partial and excess rewinds;
 * the clock-paced emulated device; the probe after the pre-fill, asked
 * again after a device that drained the buffer before it. */
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
    char what; /* 'w' writei, 'r' recover, 's' start */
    const void *buf;
    long frames_or_err;
};
static struct call calls[MAXCALLS];
static int ncalls;
static long write_script[MAXCALLS]; /* results of successive writei calls; 0 = accept all */
static int nwrites;
static int recover_result;
static long rewindable_result, rewind_result, forward_result; /* rewind_result 0: as asked */
static int rewindable_calls, rewind_calls, forward_calls;
static long rewindable_seq[4]; /* answered first, in order, before rewindable_result */
static int rewindable_seq_n;
static unsigned long rewind_asked, forward_asked;

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
snd_pcm_sframes_t __wrap_snd_pcm_rewindable(snd_pcm_t *pcm)
{
    (void)pcm;
    int i = rewindable_calls++;
    return i < rewindable_seq_n ? rewindable_seq[i] : rewindable_result;
}
snd_pcm_sframes_t __wrap_snd_pcm_rewind(snd_pcm_t *pcm, snd_pcm_uframes_t frames)
{
    (void)pcm;
    rewind_calls++;
    rewind_asked = frames;
    return rewind_result == 0 ? (snd_pcm_sframes_t)frames : rewind_result;
}
snd_pcm_sframes_t __wrap_snd_pcm_forward(snd_pcm_t *pcm, snd_pcm_uframes_t frames)
{
    (void)pcm;
    forward_calls++;
    forward_asked = frames;
    return forward_result == 0 ? (snd_pcm_sframes_t)frames : forward_result;
}
static int open_mode, open_result = -ENOENT;
int __wrap_snd_pcm_open(snd_pcm_t **pcm, const char *name, snd_pcm_stream_t stream, int mode)
{
    (void)pcm, (void)name, (void)stream;
    open_mode = mode;
    return open_result;
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
    rewindable_result = rewind_result = forward_result = 0;
    rewindable_calls = rewind_calls = forward_calls = rewindable_seq_n = 0;
    rewind_asked = forward_asked = 0;
    return 0;
}

/* A device-paced PCM with a 512-frame buffer, 32 frames kept for the device. */
static struct hd_audio fake_rewinding(void)
{
    struct hd_audio a = fake();
    a.period_frames = 256;
    a.buffer_frames = 512;
    hd_audio_configure(&a, 1, 32, 0);
    a.written = 10000;
    return a;
}

static void rewind_keeps_margin_and_limit(void **state)
{
    (void)state;
    struct hd_audio a = fake_rewinding();
    rewindable_result = 300; /* frames queued that the device has not read */
    assert_int_equal(hd_audio_rewind(&a, 1000, 0), 268);
    assert_int_equal(rewind_asked, 268);
    assert_int_equal(a.written, 10000 - 268); /* the caller writes 268 frames again */
    /* The caller can render at most 100 frames again: no more are taken. */
    assert_int_equal(hd_audio_rewind(&a, 100, 0), 100);
    assert_int_equal(rewind_asked, 100);
    assert_int_equal(a.written, 10000 - 368);
    assert_true(a.rewind);
    assert_int_equal(forward_calls, 0);
    free(a.silence);
}

static void nothing_rewindable_rewinds_nothing(void **state)
{
    (void)state;
    struct hd_audio a = fake_rewinding();
    rewindable_result = 0;
    assert_int_equal(hd_audio_rewind(&a, 1000, 0), 0);
    rewindable_result = 32; /* only the margin is queued */
    assert_int_equal(hd_audio_rewind(&a, 1000, 0), 0);
    rewindable_result = 300;
    assert_int_equal(hd_audio_rewind(&a, 0, 0), 0); /* the caller cannot render anything again */
    assert_int_equal(rewind_calls, 0);
    assert_int_equal(a.written, 10000);
    assert_true(a.rewind); /* still on: the next trigger may find frames to rewind */
    assert_int_equal(a.rewind_error, 0);
    /* Off by the board: the PCM is not even asked. */
    hd_audio_configure(&a, 0, 32, 0);
    assert_int_equal(hd_audio_rewind(&a, 1000, 0), 0);
    assert_int_equal(rewindable_calls, 3);
    /* A batch device may be reading anywhere in the current period: a period of margin at least. */
    a.batch = 1;
    hd_audio_configure(&a, 1, 32, 0);
    assert_int_equal(a.rewind_margin, 256);
    rewindable_result = 300;
    assert_int_equal(hd_audio_rewind(&a, 1000, 0), 300 - 256);
    hd_audio_configure(&a, 1, 400, 0);
    assert_int_equal(a.rewind_margin, 400);
    free(a.silence);
}

static void rewindable_errors(void **state)
{
    (void)state;
    struct hd_audio a = fake_rewinding();
    /* An xrun or suspend: nothing this time, the next write recovers it. */
    rewindable_result = -EPIPE;
    assert_int_equal(hd_audio_rewind(&a, 1000, 0), 0);
    rewindable_result = -ESTRPIPE;
    assert_int_equal(hd_audio_rewind(&a, 1000, 0), 0);
    assert_true(a.rewind);
    assert_int_equal(a.rewind_error, 0);
    /* A PCM that does not support it: off for good, the error kept for the log. */
    rewindable_result = -ENOSYS;
    assert_int_equal(hd_audio_rewind(&a, 1000, 0), 0);
    assert_false(a.rewind);
    assert_int_equal(a.rewind_error, -ENOSYS);
    rewindable_result = 300;
    assert_int_equal(hd_audio_rewind(&a, 1000, 0), 0);
    assert_int_equal(rewindable_calls, 3); /* not asked again */
    assert_int_equal(rewind_calls, 0);
    assert_int_equal(a.written, 10000);
    free(a.silence);
}

static void partial_and_failed_rewinds(void **state)
{
    (void)state;
    struct hd_audio a = fake_rewinding();
    rewindable_result = 300;
    rewind_result = 20; /* went back 20 of the 268 asked: write 20 again */
    assert_int_equal(hd_audio_rewind(&a, 1000, 0), 20);
    assert_int_equal(rewind_asked, 268);
    assert_int_equal(a.written, 10000 - 20);
    /* More than asked (a plugin bug): the excess is forwarded again. */
    rewind_result = 300;
    assert_int_equal(hd_audio_rewind(&a, 1000, 0), 268);
    assert_int_equal(forward_calls, 1);
    assert_int_equal(forward_asked, 32);
    assert_int_equal(a.written, 10000 - 20 - 268);
    /* The rewind itself hits an xrun: nothing rewound, still on. */
    rewind_result = -EPIPE;
    assert_int_equal(hd_audio_rewind(&a, 1000, 0), 0);
    assert_true(a.rewind);
    /* ...or fails for good. */
    rewind_result = -EBADFD;
    assert_int_equal(hd_audio_rewind(&a, 1000, 0), 0);
    assert_false(a.rewind);
    assert_int_equal(a.rewind_error, -EBADFD);
    assert_int_equal(a.written, 10000 - 20 - 268);
    free(a.silence);
}

static void clock_paced_device_is_emulated(void **state)
{
    (void)state;
    struct hd_audio a = fake();
    a.period_frames = 64;
    a.buffer_frames = 128;
    a.rate_hz = 48000;
    hd_audio_configure(&a, 1, 32, 1);
    a.start_ns = 5000000000u;
    a.written = 128 + 64; /* pre-fill and one period */
    /* 1 ms after the start the device has played 48 frames: 144 are queued. */
    const uint64_t t = a.start_ns + 1000000u;
    assert_int_equal(hd_audio_clock_queued(&a, t), 144);
    rewindable_result = 192; /* the file plugin holds everything written */
    assert_int_equal(hd_audio_rewind(&a, 1000, t), 144 - 32);
    assert_int_equal(a.written, 192 - 112);
    /* Later than everything written (the writer fell behind): nothing queued. */
    a.written = 192;
    assert_int_equal(hd_audio_clock_queued(&a, a.start_ns + 10000000u), 0);
    assert_int_equal(hd_audio_rewind(&a, 1000, a.start_ns + 10000000u), 0);
    assert_int_equal(hd_audio_clock_queued(&a, a.start_ns - 1), 192);
    /* The next period is due when the device has room for it: written + 64 -
     * 128 = 128 frames played, 128 / 48000 s = 2666666.67 ns -> 2666667. */
    assert_int_equal(hd_audio_clock_due_ns(&a) - a.start_ns, 2666667);
    a.written = 128;
    assert_int_equal(hd_audio_clock_due_ns(&a) - a.start_ns, 1333334);
    a.written = 64; /* less than a buffer minus a period: due at once */
    assert_int_equal(hd_audio_clock_due_ns(&a), a.start_ns);
    free(a.silence);
}

static int count_calls(char what)
{
    int n = 0;
    for (int i = 0; i < ncalls; i++)
        n += calls[i].what == what;
    return n;
}

static void probe_after_prefill(void **state)
{
    (void)state;
    struct hd_audio a = fake_rewinding();
    rewindable_result = 500;
    assert_int_equal(hd_audio_rewind_probe(&a), 500);
    assert_true(a.rewind);
    assert_int_equal(ncalls, 0); /* asked once, nothing primed */
    /* Nothing rewindable with a full buffer, every time: this PCM cannot. */
    rewindable_result = 0;
    rewindable_calls = 0;
    assert_int_equal(hd_audio_rewind_probe(&a), 0);
    assert_false(a.rewind);
    assert_int_equal(a.rewind_error, -ENOTSUP);
    assert_int_equal(rewindable_calls, HD_AUDIO_PROBE_TRIES);
    assert_int_equal(count_calls('w'), 2 * (HD_AUDIO_PROBE_TRIES - 1)); /* primed again between: 2 periods each */
    free(a.silence);
    a = fake_rewinding();
    rewindable_result = -EINVAL; /* a lasting error: not asked again */
    rewindable_calls = 0;
    assert_int_equal(hd_audio_rewind_probe(&a), -EINVAL);
    assert_false(a.rewind);
    assert_int_equal(a.rewind_error, -EINVAL);
    assert_int_equal(rewindable_calls, 1);
    free(a.silence);
}

/* The device read the whole buffer before the question (a stall at start):
 * 0, or an xrun, is asked again after the buffer is primed again, and the
 * PCM keeps rewinding. */
static void probe_asks_again_after_a_drained_buffer(void **state)
{
    (void)state;
    struct hd_audio a = fake_rewinding();
    rewindable_seq[0] = 0;
    rewindable_seq_n = 1;
    rewindable_result = 480;
    assert_int_equal(hd_audio_rewind_probe(&a), 480);
    assert_true(a.rewind);
    assert_int_equal(count_calls('w'), 2); /* one prime: 512 frames in periods of 256 */
    assert_int_equal(count_calls('r'), 0);
    assert_int_equal(a.written, 512);

    reset(NULL);
    free(a.silence);
    a = fake_rewinding();
    rewindable_seq[0] = -EPIPE; /* drained into an xrun: recovered, then primed */
    rewindable_seq_n = 1;
    rewindable_result = 480;
    assert_int_equal(hd_audio_rewind_probe(&a), 480);
    assert_true(a.rewind);
    assert_int_equal(calls[0].what, 'r');
    assert_int_equal(calls[0].frames_or_err, -EPIPE);
    assert_int_equal(a.xruns, 1);
    assert_int_equal(count_calls('w'), 2);

    reset(NULL);
    free(a.silence);
    a = fake_rewinding();
    rewindable_seq[0] = 0; /* and drained again while primed: recovered, primed again */
    rewindable_seq_n = 1;
    write_script[0] = -EPIPE;
    rewindable_result = 480;
    assert_int_equal(hd_audio_rewind_probe(&a), 480);
    assert_true(a.rewind);
    assert_int_equal(count_calls('r'), 1);
    assert_int_equal(a.xruns, 1);
    assert_int_equal(count_calls('w'), 3); /* the failed write, then a whole prime */

    reset(NULL);
    free(a.silence);
    a = fake_rewinding();
    rewindable_seq[0] = -ESTRPIPE; /* suspended, and the recovery fails: that error, rewinding off */
    rewindable_seq_n = 1;
    recover_result = -ENODEV;
    rewindable_result = 480;
    assert_int_equal(hd_audio_rewind_probe(&a), -ENODEV);
    assert_false(a.rewind);
    assert_int_equal(a.rewind_error, -ENODEV);
    assert_int_equal(a.suspends, 1);
    assert_int_equal(rewindable_calls, 1);
    free(a.silence);
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

/* The open never waits for a device another program holds (a blocking
 * open() would, and SIGTERM could not reach the drain): non-blocking, and
 * EBUSY says who is in the way. */
static void open_does_not_wait_for_a_busy_device(void **state)
{
    (void)state;
    struct hd_board b;
    hd_board_defaults(&b);
    strcpy(b.path, "board.ini");
    strcpy(b.alsa_device, "hw:0");
    struct hd_audio a;
    char err[HD_ERR_MAX] = "";
    open_result = -EBUSY;
    assert_int_equal(hd_audio_open(&a, &b, NULL, err), -EBUSY);
    open_result = -ENOENT;
    assert_true(open_mode & SND_PCM_NONBLOCK);
    assert_non_null(strstr(err, "(another program is using it)"));
}

/* A failing device: errors within a second of each other make one stretch,
 * whatever succeeded between them; 3 s of it gives up; a second without an
 * error ends the stretch. */
static void failing_device_policy(void **state)
{
    (void)state;
    const uint64_t ms = 1000000u;
    struct hd_audio_health h = {0};
    assert_int_equal(hd_audio_health_write(&h, 0, 5 * ms), HD_AUDIO_OK);
    /* An error every other period (a plugin failing half its writes). */
    uint64_t t = 1000 * ms;
    for (; t < 1000 * ms + 2999 * ms; t += ms)
        assert_int_not_equal(hd_audio_health_write(&h, (t / ms) % 2 ? 0 : -EIO, t), HD_AUDIO_GAVE_UP);
    assert_int_equal(hd_audio_health_write(&h, -EIO, t + ms), HD_AUDIO_GAVE_UP);
    /* Errors 0.9 s apart keep one stretch; 1.1 s apart never give up. */
    h = (struct hd_audio_health){0};
    enum hd_audio_verdict v = HD_AUDIO_OK;
    for (t = 10000 * ms; t <= 10000 * ms + 2700 * ms; t += 900 * ms)
        v = hd_audio_health_write(&h, -EIO, t);
    assert_int_equal(v, HD_AUDIO_FAILING);
    assert_int_equal(hd_audio_health_write(&h, -EIO, t), HD_AUDIO_GAVE_UP); /* 3.6 s */
    h = (struct hd_audio_health){0};
    for (t = 20000 * ms; t < 20000 * ms + 30000 * ms; t += 1100 * ms)
        assert_int_equal(hd_audio_health_write(&h, -EIO, t), HD_AUDIO_FAILING);
    assert_int_equal(hd_audio_health_write(&h, 0, t + 1200 * ms), HD_AUDIO_OK); /* the stretch is over */
}

/* A PCM that takes frames faster than it can play them does not pace. */
static void unpaced_device_is_detected(void **state)
{
    (void)state;
    const uint64_t s0 = 7000000000u;
    /* A real device: 1 s at 48 kHz has taken at most 48000 + its buffer. */
    assert_int_equal(hd_audio_health_pace(48000 + 128, s0, s0 + 1000000000u, 48000, 128), HD_AUDIO_OK);
    /* A day later, its clock 100 ppm fast: still a device. */
    const uint64_t day = 86400ull * 1000000000u;
    assert_int_equal(hd_audio_health_pace((uint64_t)(86400.0 * 48000 * 1.0001), s0, s0 + day, 48000, 128), HD_AUDIO_OK);
    /* The null plugin: 10 s of frames in 0.1 s. */
    assert_int_equal(hd_audio_health_pace(480000, s0, s0 + 100000000u, 48000, 128), HD_AUDIO_UNPACED);
    /* The bound: 1 s ahead (+5 % of the elapsed time) and the buffer. */
    assert_int_equal(hd_audio_health_pace(48000 + 128, s0, s0, 48000, 128), HD_AUDIO_OK);
    assert_int_equal(hd_audio_health_pace(48000 + 129, s0, s0, 48000, 128), HD_AUDIO_UNPACED);
}

/* libasound's messages, once captured, are kept (the first one's text and a
 * count) instead of printed, and handed over once. */
static void library_messages_are_kept_for_the_log(void **state)
{
    (void)state;
    hd_audio_lib_messages_capture();
    char first[512];
    (void)hd_audio_lib_messages_take(first, sizeof first);
    snd_pcm_t *pcm;
    /* The real open (not wrapped: snd_pcm_open_lconf) with an empty local
     * config: libasound reports the unknown PCM through its handler. */
    snd_config_t *top;
    assert_int_equal(snd_config_top(&top), 0);
    assert_true(snd_pcm_open_lconf(&pcm, "nosuchpcm", SND_PCM_STREAM_PLAYBACK, 0, top) < 0);
    snd_config_delete(top);
    unsigned long n = hd_audio_lib_messages_take(first, sizeof first);
    assert_true(n >= 1);
    assert_non_null(strstr(first, "Unknown PCM nosuchpcm"));
    assert_int_equal(hd_audio_lib_messages_take(first, sizeof first), 0); /* handed over once */
    assert_string_equal(first, "");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(xrun_recovers_and_reprimes, reset),
        cmocka_unit_test_setup(suspend_recovers, reset),
        cmocka_unit_test_setup(failed_recovery_is_reported, reset),
        cmocka_unit_test_setup(other_errors_and_partial_writes, reset),
        cmocka_unit_test_setup(open_failure_names_device_and_board, reset),
        cmocka_unit_test_setup(open_does_not_wait_for_a_busy_device, reset),
        cmocka_unit_test(failing_device_policy),
        cmocka_unit_test(unpaced_device_is_detected),
        cmocka_unit_test(library_messages_are_kept_for_the_log),
        cmocka_unit_test_setup(rewind_keeps_margin_and_limit, reset),
        cmocka_unit_test_setup(nothing_rewindable_rewinds_nothing, reset),
        cmocka_unit_test_setup(rewindable_errors, reset),
        cmocka_unit_test_setup(probe_asks_again_after_a_drained_buffer, reset),
        cmocka_unit_test_setup(partial_and_failed_rewinds, reset),
        cmocka_unit_test_setup(clock_paced_device_is_emulated, reset),
        cmocka_unit_test_setup(probe_after_prefill, reset),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
