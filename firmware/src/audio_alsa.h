/* audio_alsa.h - thin ALSA playback shim: open with the board's parameters,
 * pre-fill with silence and start, write periods, recover xruns. */
#ifndef HD_AUDIO_ALSA_H
#define HD_AUDIO_ALSA_H

#include "hd_defs.h"
#include "board.h"

#include <alsa/asoundlib.h>
#include <poll.h>
#include <stdint.h>

#define HD_AUDIO_MAX_PFDS 8

struct hd_audio {
    snd_pcm_t *pcm;
    snd_config_t *lconf; /* local config from [alsa] config, or NULL */
    uint32_t channels, rate_hz;
    snd_pcm_uframes_t period_frames, buffer_frames; /* as granted by the device */
    size_t frame_bytes;
    void *silence;                    /* one period of zeros */
    uint64_t xruns, suspends, errors; /* written by the audio thread only */
    /* Rewinding queued frames (a trigger answered at once). */
    int rewind;                      /* 1: enabled; 0: off by the board, or disabled after an error */
    int rewind_error;                /* the error that disabled it (negative errno), 0 if none */
    snd_pcm_uframes_t rewind_margin; /* queued frames never rewound: the device may be reading them */
    int batch;                       /* the driver reports its position per period (hw_params_is_batch) */
    /* Clock pacing (file/null plugins never block nor advance a hardware
     * pointer): a device is emulated that starts playing the pre-fill at
     * start_ns and plays rate_hz frames per second; it limits the rewinds
     * to the frames it has not played yet and says when a period is due. */
    int clock_paced;
    uint64_t start_ns; /* CLOCK_MONOTONIC when the pre-fill started playing */
    uint64_t written;  /* frames written since the last pre-fill, the pre-fill included */
};

/* Open `device` (or the board's [alsa] device when NULL), through the board's
 * local ALSA config if it has one, and set hw/sw parameters. One-line error
 * naming the device and the board file. */
int hd_audio_open(struct hd_audio *a, const struct hd_board *b, const char *device, char err[HD_ERR_MAX]);

/* Fill the whole buffer with silence and start the stream. Returns the frames
 * written or a negative errno. */
long hd_audio_prime(struct hd_audio *a);

/* Write one period. An xrun (-EPIPE) or a suspend (-ESTRPIPE) is recovered
 * with snd_pcm_recover, the buffer is primed again and the period is then
 * written: never fatal. Returns 0, or a negative errno if recovery failed. */
int hd_audio_write(struct hd_audio *a, const void *frames_buf, uint32_t frames);

/* Enable rewinding (the board's [alsa] rewind, rewind_margin_frames) and,
 * with clock pacing, the emulated device. Call before hd_audio_prime. A
 * batch device (position known only per period: the hardware may be
 * reading anywhere in the current period) gets at least a period of margin. */
void hd_audio_configure(struct hd_audio *a, int rewind, snd_pcm_uframes_t margin, int clock_paced);

/* After hd_audio_prime: does the PCM rewind? With a full buffer queued,
 * snd_pcm_rewindable must report frames. None, or an xrun, may only mean the
 * device read the whole buffer before the question came (a stall longer
 * than the buffer, on a board loaded at start): the buffer is primed again
 * (an xrun recovered first) and the question asked again, up to
 * HD_AUDIO_PROBE_TRIES times in all. A PCM (plugin) that reports none every
 * time, or a lasting error, cannot, and rewinding is disabled. Returns the
 * frames it can rewind now (> 0), 0 or a negative errno when it cannot. */
#define HD_AUDIO_PROBE_TRIES 3
snd_pcm_sframes_t hd_audio_rewind_probe(struct hd_audio *a);

/* Rewind the queued frames the device has not started to read, keeping
 * rewind_margin frames, and at most `limit` (what the caller can render
 * again). Returns the frames rewound (the caller writes as many again), 0
 * when there is nothing to rewind or rewinding is off. An xrun or suspend
 * (-EPIPE, -ESTRPIPE, -EAGAIN) rewinds nothing this time (the next write
 * recovers it); any other error disables rewinding for good and is kept
 * in rewind_error. Real-time safe. now_ns: CLOCK_MONOTONIC (clock pacing). */
snd_pcm_uframes_t hd_audio_rewind(struct hd_audio *a, snd_pcm_uframes_t limit, uint64_t now_ns);

/* Clock pacing: frames of the emulated device's queue not played at now_ns,
 * and when the next period is due (the queue has a period of room). */
snd_pcm_uframes_t hd_audio_clock_queued(const struct hd_audio *a, uint64_t now_ns);
uint64_t hd_audio_clock_due_ns(const struct hd_audio *a);

/* Device pacing: the PCM's poll descriptors (at most max), to poll next to
 * other fds; then whether they say the device has room (1), an error (< 0,
 * the next write recovers it) or neither (0). */
int hd_audio_poll_fds(struct hd_audio *a, struct pollfd *pfd, int max);
int hd_audio_poll_ready(struct hd_audio *a, struct pollfd *pfd, int n);

/* Stop: drain (play what is queued) or drop it. */
void hd_audio_close(struct hd_audio *a, int drain);

/* ---- capture (hapticd --measure: the board's [capture]) ---- */

struct hd_capture {
    snd_pcm_t *pcm;
    uint32_t channels, rate_hz;
    snd_pcm_uframes_t period_frames, buffer_frames;
    size_t frame_bytes;
};

/* Open the board's [capture] device non-blocking (reads return -EAGAIN
 * when nothing is there), through the local ALSA config `lconf` when the
 * board has one (the playback's, hd_audio.lconf), with its channels,
 * format and rate exactly, periods of `period_frames` and a buffer of at
 * least `buffer_frames`. One-line error naming the device and the board. */
int hd_capture_open(struct hd_capture *c, const struct hd_board *b, snd_config_t *lconf,
                    snd_pcm_uframes_t period_frames, snd_pcm_uframes_t buffer_frames, char err[HD_ERR_MAX]);
void hd_capture_close(struct hd_capture *c);

/* libasound's own messages. By default it prints them to stderr, several
 * lines per failure and one per failed write (hundreds a second from a
 * plugin that cannot write its file). Once hd_audio_lib_messages_capture()
 * ran, they are kept instead: the first one's text and a count, written
 * without locks or allocation (the audio thread may be the one that fails),
 * and hapticd logs them through its own log: hd_audio_lib_messages_take()
 * returns how many came since the last take and the first of them. */
void hd_audio_lib_messages_capture(void);
unsigned long hd_audio_lib_messages_take(char *first, size_t cap);

/* When a device that fails is a failed device. A write error (the audio
 * thread's period could not be written) opens a failing stretch; an error
 * within HD_AUDIO_ERROR_GAP_NS of the previous one continues it, however
 * many periods succeeded between them (a plugin that fails every other
 * write is failing); the stretch lasting HD_AUDIO_GIVE_UP_NS gives up.
 * Device pacing on a PCM that never blocks (the null plugin: it takes frames
 * faster than any clock) is detected too: more frames written than the
 * time since the start, plus 5 % (clock drift) and HD_AUDIO_AHEAD_NS, can
 * have played. Pure: real-time safe. */
#define HD_AUDIO_ERROR_GAP_NS 1000000000ull
#define HD_AUDIO_GIVE_UP_NS 3000000000ull
#define HD_AUDIO_AHEAD_NS 1000000000ull

enum hd_audio_verdict { HD_AUDIO_OK = 0, HD_AUDIO_FAILING, HD_AUDIO_GAVE_UP, HD_AUDIO_UNPACED };

struct hd_audio_health {
    uint64_t stretch_start_ns; /* first error of the current failing stretch; 0: none */
    uint64_t last_error_ns;
};

/* A period's outcome at now_ns: write_rc from hd_audio_write. */
enum hd_audio_verdict hd_audio_health_write(struct hd_audio_health *h, int write_rc, uint64_t now_ns);
/* Device pacing: `written` frames since the stream started at start_ns, at
 * rate_hz, with a buffer of buffer_frames: HD_AUDIO_UNPACED if the device
 * took more than it can have played by now_ns plus HD_AUDIO_AHEAD_NS. */
enum hd_audio_verdict hd_audio_health_pace(uint64_t written, uint64_t start_ns, uint64_t now_ns, uint32_t rate_hz,
                                           uint64_t buffer_frames);

#endif
