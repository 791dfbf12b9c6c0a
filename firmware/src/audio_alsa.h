/* audio_alsa.h - thin ALSA playback shim: open with the board's parameters,
 * pre-fill with silence and start, write periods, recover xruns. */
#ifndef HD_AUDIO_ALSA_H
#define HD_AUDIO_ALSA_H

#include "board.h"

#include <alsa/asoundlib.h>
#include <stdint.h>

struct hd_audio {
    snd_pcm_t *pcm;
    snd_config_t *lconf;              /* local config from [alsa] config, or NULL */
    uint32_t channels, rate_hz;
    snd_pcm_uframes_t period_frames, buffer_frames;  /* as granted by the device */
    size_t frame_bytes;
    void *silence;                    /* one period of zeros */
    uint64_t xruns, suspends, errors; /* written by the audio thread only */
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

/* Device pacing: block until the device can take a period (up to 100 ms),
 * so the period is rendered just before it is written, with the freshest
 * triggers, instead of going stale while a blocking write waits for room.
 * Returns 1 when ready, 0 on timeout, negative errno (an xrun: the next
 * hd_audio_write recovers it). */
int hd_audio_wait(struct hd_audio *a);

/* Stop: drain (play what is queued) or drop it. */
void hd_audio_close(struct hd_audio *a, int drain);

#endif
