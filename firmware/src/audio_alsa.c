/* audio_alsa.c - ALSA playback shim (see alsa-utils aplay.c for the
 * reference xrun/suspend handling; our buffers are a few ms, not 500 ms). */
#define _DEFAULT_SOURCE /* alloca for snd_pcm_*_params_alloca */
#include "audio_alsa.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int load_config(const char *path, snd_config_t **out)
{
    snd_config_t *top = NULL;
    snd_input_t *in = NULL;
    int rc = snd_config_top(&top);
    if (rc < 0)
        return rc;
    rc = snd_input_stdio_open(&in, path, "r");
    if (rc >= 0) {
        rc = snd_config_load(top, in);
        snd_input_close(in);
    }
    if (rc < 0) {
        snd_config_delete(top);
        return rc;
    }
    *out = top;
    return 0;
}

static int set_params(struct hd_audio *a, const struct hd_board *b, const char **what)
{
    snd_pcm_hw_params_t *hw;
    snd_pcm_sw_params_t *sw;
    snd_pcm_hw_params_alloca(&hw);
    snd_pcm_sw_params_alloca(&sw);
    int rc;
    unsigned rate = b->rate_hz;
    snd_pcm_uframes_t period = b->period_frames;
    unsigned periods = b->periods;
    snd_pcm_format_t fmt = b->format == HD_FMT_S16_LE ? SND_PCM_FORMAT_S16_LE : SND_PCM_FORMAT_S32_LE;
    if ((rc = snd_pcm_hw_params_any(a->pcm, hw)) < 0)
        return *what = "hw_params_any", rc;
    if ((rc = snd_pcm_hw_params_set_rate_resample(a->pcm, hw, 0)) < 0)
        return *what = "rate_resample off", rc;
    if ((rc = snd_pcm_hw_params_set_access(a->pcm, hw, SND_PCM_ACCESS_RW_INTERLEAVED)) < 0)
        return *what = "interleaved access", rc;
    if ((rc = snd_pcm_hw_params_set_format(a->pcm, hw, fmt)) < 0)
        return *what = "[alsa] format", rc;
    if ((rc = snd_pcm_hw_params_set_channels(a->pcm, hw, b->channels)) < 0)
        return *what = "[alsa] channels", rc;
    if ((rc = snd_pcm_hw_params_set_rate(a->pcm, hw, rate, 0)) < 0)
        return *what = "[alsa] rate_hz", rc;
    if ((rc = snd_pcm_hw_params_set_period_size_near(a->pcm, hw, &period, NULL)) < 0)
        return *what = "[alsa] period_frames", rc;
    if ((rc = snd_pcm_hw_params_set_periods_near(a->pcm, hw, &periods, NULL)) < 0)
        return *what = "[alsa] periods", rc;
    if ((rc = snd_pcm_hw_params(a->pcm, hw)) < 0)
        return *what = "hw_params", rc;
    snd_pcm_hw_params_get_period_size(hw, &a->period_frames, NULL);
    snd_pcm_hw_params_get_buffer_size(hw, &a->buffer_frames);
    if ((rc = snd_pcm_sw_params_current(a->pcm, sw)) < 0)
        return *what = "sw_params_current", rc;
    if ((rc = snd_pcm_sw_params_set_start_threshold(a->pcm, sw, a->buffer_frames)) < 0)
        return *what = "start_threshold", rc;
    if ((rc = snd_pcm_sw_params_set_avail_min(a->pcm, sw, a->period_frames)) < 0)
        return *what = "avail_min", rc;
    if ((rc = snd_pcm_sw_params(a->pcm, sw)) < 0)
        return *what = "sw_params", rc;
    return 0;
}

int hd_audio_open(struct hd_audio *a, const struct hd_board *b, const char *device, char err[HD_ERR_MAX])
{
    memset(a, 0, sizeof *a);
    if (!device)
        device = b->alsa_device;
    a->channels = b->channels;
    a->rate_hz = b->rate_hz;
    a->frame_bytes = (size_t)b->channels * (b->format == HD_FMT_S16_LE ? 2 : 4);
    int rc;
    if (b->alsa_config[0] && (rc = load_config(b->alsa_config, &a->lconf)) < 0) {
        snprintf(err, HD_ERR_MAX, "%s: [alsa] config '%s': cannot load ALSA configuration: %s", b->path,
                 b->alsa_config, snd_strerror(rc));
        return rc;
    }
    rc = a->lconf ? snd_pcm_open_lconf(&a->pcm, device, SND_PCM_STREAM_PLAYBACK, 0, a->lconf)
                  : snd_pcm_open(&a->pcm, device, SND_PCM_STREAM_PLAYBACK, 0);
    if (rc < 0) {
        snprintf(err, HD_ERR_MAX, "cannot open ALSA device '%s' ([alsa] device in %s): %s", device, b->path,
                 snd_strerror(rc));
        a->pcm = NULL;
        goto fail;
    }
    const char *what = "";
    if ((rc = set_params(a, b, &what)) < 0) {
        snprintf(err, HD_ERR_MAX, "ALSA device '%s' ([alsa] in %s) refused %s: %s", device, b->path, what,
                 snd_strerror(rc));
        goto fail;
    }
    a->silence = calloc(a->period_frames, a->frame_bytes);
    if (!a->silence) {
        rc = -ENOMEM;
        snprintf(err, HD_ERR_MAX, "out of memory opening '%s'", device);
        goto fail;
    }
    return 0;
fail:
    hd_audio_close(a, 0);
    return rc;
}

/* Write all frames, blocking; -EPIPE/-ESTRPIPE are returned to the caller. */
static int write_all(struct hd_audio *a, const uint8_t *p, snd_pcm_uframes_t frames)
{
    while (frames > 0) {
        snd_pcm_sframes_t r = snd_pcm_writei(a->pcm, p, frames);
        if (r == -EAGAIN || r == -EINTR)
            continue;
        if (r < 0)
            return (int)r;
        p += (size_t)r * a->frame_bytes;
        frames -= (snd_pcm_uframes_t)r;
    }
    return 0;
}

long hd_audio_prime(struct hd_audio *a)
{
    snd_pcm_uframes_t done = 0;
    while (done < a->buffer_frames) {
        snd_pcm_uframes_t n = a->buffer_frames - done;
        if (n > a->period_frames)
            n = a->period_frames;
        int rc = write_all(a, a->silence, n);
        if (rc < 0)
            return rc;
        done += n;
    }
    /* The start threshold (a full buffer) normally started it already. */
    int rc = snd_pcm_start(a->pcm);
    if (rc < 0 && rc != -EBADFD)
        return rc;
    return (long)done;
}

int hd_audio_write(struct hd_audio *a, const void *frames_buf, uint32_t frames)
{
    for (int attempt = 0; attempt < 4; attempt++) {
        int rc = write_all(a, frames_buf, frames);
        if (rc == 0)
            return 0;
        if (rc != -EPIPE && rc != -ESTRPIPE) {
            a->errors++;
            return rc;
        }
        if (rc == -EPIPE)
            a->xruns++;
        else
            a->suspends++;
        rc = snd_pcm_recover(a->pcm, rc, 1);
        if (rc < 0) {
            a->errors++;
            return rc;
        }
        long primed = hd_audio_prime(a);
        if (primed < 0 && primed != -EPIPE && primed != -ESTRPIPE) {
            a->errors++;
            return (int)primed;
        }
    }
    a->errors++;
    return -EIO;
}

int hd_audio_wait(struct hd_audio *a)
{
    return snd_pcm_wait(a->pcm, 100);
}

void hd_audio_close(struct hd_audio *a, int drain)
{
    if (a->pcm) {
        if (drain)
            snd_pcm_drain(a->pcm);
        else
            snd_pcm_drop(a->pcm);
        snd_pcm_close(a->pcm);
    }
    if (a->lconf)
        snd_config_delete(a->lconf);
    free(a->silence);
    memset(a, 0, sizeof *a);
}
