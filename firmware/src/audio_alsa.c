/* audio_alsa.c - ALSA playback shim (see alsa-utils aplay.c for the
 * reference xrun/suspend handling; our buffers are a few ms, not 500 ms). */
#define _DEFAULT_SOURCE /* alloca for snd_pcm_*_params_alloca */
#include "audio_alsa.h"

#include <errno.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

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
    a->batch = snd_pcm_hw_params_is_batch(hw) == 1;
    if ((rc = snd_pcm_sw_params_current(a->pcm, sw)) < 0)
        return *what = "sw_params_current", rc;
    if ((rc = snd_pcm_sw_params_set_start_threshold(a->pcm, sw, a->buffer_frames)) < 0)
        return *what = "start_threshold", rc;
    if ((rc = snd_pcm_sw_params_set_avail_min(a->pcm, sw, a->period_frames)) < 0)
        return *what = "avail_min", rc;
    /* At an underrun the hardware runs past the last frame written (a DMA
     * burst, a timer tick) into the ring buffer's old contents: a buffer-old
     * drive signal on the exciters. ALSA zeroes what has been played when the
     * silence size is the boundary and the threshold 0; rewinding only ever
     * reclaims frames not yet played, so it never meets the zeroed area. */
    snd_pcm_uframes_t boundary;
    if ((rc = snd_pcm_sw_params_get_boundary(sw, &boundary)) < 0)
        return *what = "boundary", rc;
    if ((rc = snd_pcm_sw_params_set_silence_threshold(a->pcm, sw, 0)) < 0)
        return *what = "silence_threshold", rc;
    if ((rc = snd_pcm_sw_params_set_silence_size(a->pcm, sw, boundary)) < 0)
        return *what = "silence_size", rc;
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
        snprintf(err, HD_ERR_MAX, "%s: [alsa] config '%s': cannot load ALSA configuration: %s", b->path, b->alsa_config,
                 snd_strerror(rc));
        return rc;
    }
    /* Opened non-blocking: a device another process holds is refused with
     * EBUSY at once instead of waiting in open() for it to be released
     * (where SIGTERM could not reach the drain); then blocking for writes. */
    rc = a->lconf ? snd_pcm_open_lconf(&a->pcm, device, SND_PCM_STREAM_PLAYBACK, SND_PCM_NONBLOCK, a->lconf)
                  : snd_pcm_open(&a->pcm, device, SND_PCM_STREAM_PLAYBACK, SND_PCM_NONBLOCK);
    if (rc < 0) {
        snprintf(err, HD_ERR_MAX, "cannot open ALSA device '%s' ([alsa] device in %s): %s%s", device, b->path,
                 snd_strerror(rc), rc == -EBUSY ? " (another program is using it)" : "");
        a->pcm = NULL;
        goto fail;
    }
    if ((rc = snd_pcm_nonblock(a->pcm, 0)) < 0) {
        snprintf(err, HD_ERR_MAX, "ALSA device '%s' ([alsa] in %s): cannot set blocking mode: %s", device, b->path,
                 snd_strerror(rc));
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
    a->written = done;
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    a->start_ns = (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
    return (long)done;
}

/* An xrun (-EPIPE) or a suspend (-ESTRPIPE): counted, then recovered quietly. */
static int recover(struct hd_audio *a, long err)
{
    if (err == -EPIPE)
        a->xruns++;
    else
        a->suspends++;
    return snd_pcm_recover(a->pcm, (int)err, 1);
}

int hd_audio_write(struct hd_audio *a, const void *frames_buf, uint32_t frames)
{
    for (int attempt = 0; attempt < 4; attempt++) {
        int rc = write_all(a, frames_buf, frames);
        if (rc == 0) {
            a->written += frames;
            return 0;
        }
        if (rc != -EPIPE && rc != -ESTRPIPE) {
            a->errors++;
            return rc;
        }
        rc = recover(a, rc);
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

void hd_audio_configure(struct hd_audio *a, int rewind, snd_pcm_uframes_t margin, int clock_paced)
{
    a->rewind = rewind;
    a->rewind_margin = a->batch && margin < a->period_frames ? a->period_frames : margin;
    a->clock_paced = clock_paced;
}

static int transient(long err) { return err == -EPIPE || err == -ESTRPIPE || err == -EAGAIN || err == -EINTR; }

static void rewind_disable(struct hd_audio *a, long err)
{
    a->rewind = 0;
    a->rewind_error = err < 0 ? (int)err : -ENOTSUP;
}

snd_pcm_sframes_t hd_audio_rewind_probe(struct hd_audio *a)
{
    if (!a->rewind)
        return 0;
    snd_pcm_sframes_t can = 0;
    for (int attempt = 0; attempt < HD_AUDIO_PROBE_TRIES; attempt++) {
        if (attempt > 0) { /* drained before the question: fill the buffer again */
            long rc = can == -EPIPE || can == -ESTRPIPE ? recover(a, can) : 0;
            if (rc >= 0)
                rc = hd_audio_prime(a);
            if (rc < 0) {
                can = rc;
                if (rc == -EPIPE || rc == -ESTRPIPE)
                    continue; /* drained while priming: the next try recovers it */
                break;
            }
        }
        can = snd_pcm_rewindable(a->pcm);
        if (can > 0)
            return can;
        if (can < 0 && !transient(can))
            break;
    }
    rewind_disable(a, can);
    return can;
}

snd_pcm_uframes_t hd_audio_clock_queued(const struct hd_audio *a, uint64_t now_ns)
{
    uint64_t played = now_ns > a->start_ns ? (now_ns - a->start_ns) * a->rate_hz / 1000000000u : 0;
    return played < a->written ? (snd_pcm_uframes_t)(a->written - played) : 0;
}

uint64_t hd_audio_clock_due_ns(const struct hd_audio *a)
{
    /* The period is due when the emulated device has played written +
     * period - buffer frames; ceil so the room is really there. */
    uint64_t need = a->written + a->period_frames;
    if (need <= a->buffer_frames)
        return a->start_ns;
    return a->start_ns + ((need - a->buffer_frames) * 1000000000u + a->rate_hz - 1) / a->rate_hz;
}

snd_pcm_uframes_t hd_audio_rewind(struct hd_audio *a, snd_pcm_uframes_t limit, uint64_t now_ns)
{
    if (!a->rewind)
        return 0;
    snd_pcm_sframes_t can = snd_pcm_rewindable(a->pcm);
    if (can < 0) {
        if (!transient(can))
            rewind_disable(a, can);
        return 0;
    }
    if (a->clock_paced) {
        snd_pcm_uframes_t queued = hd_audio_clock_queued(a, now_ns);
        if ((snd_pcm_uframes_t)can > queued)
            can = (snd_pcm_sframes_t)queued;
    }
    if ((snd_pcm_uframes_t)can <= a->rewind_margin)
        return 0;
    snd_pcm_uframes_t n = (snd_pcm_uframes_t)can - a->rewind_margin;
    if (n > limit)
        n = limit;
    if (n == 0)
        return 0;
    snd_pcm_sframes_t r = snd_pcm_rewind(a->pcm, n);
    if (r < 0) {
        if (!transient(r))
            rewind_disable(a, r);
        return 0;
    }
    if ((snd_pcm_uframes_t)r > n) {
        /* Went back further than asked (a plugin bug): forward the excess so
         * the caller's count of frames to write again stays exact. */
        snd_pcm_sframes_t f = snd_pcm_forward(a->pcm, (snd_pcm_uframes_t)r - n);
        if (f != (snd_pcm_sframes_t)((snd_pcm_uframes_t)r - n)) {
            rewind_disable(a, f < 0 ? f : -EIO);
            return 0; /* unknown position: the next write errs or xruns, and is recovered */
        }
        r = (snd_pcm_sframes_t)n;
    }
    a->written -= (uint64_t)r;
    return (snd_pcm_uframes_t)r;
}

int hd_audio_poll_fds(struct hd_audio *a, struct pollfd *pfd, int max)
{
    int n = snd_pcm_poll_descriptors_count(a->pcm);
    if (n <= 0 || n > max)
        return n <= 0 ? (n < 0 ? n : -EINVAL) : -E2BIG;
    return snd_pcm_poll_descriptors(a->pcm, pfd, (unsigned)n);
}

int hd_audio_poll_ready(struct hd_audio *a, struct pollfd *pfd, int n)
{
    unsigned short revents = 0;
    int rc = snd_pcm_poll_descriptors_revents(a->pcm, pfd, (unsigned)n, &revents);
    if (rc < 0)
        return rc;
    if (revents & (POLLERR | POLLNVAL))
        return -EPIPE;
    return (revents & POLLOUT) != 0;
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

/* ---- capture ---- */

int hd_capture_open(struct hd_capture *c, const struct hd_board *b, snd_config_t *lconf,
                    snd_pcm_uframes_t period_frames, snd_pcm_uframes_t buffer_frames, char err[HD_ERR_MAX])
{
    memset(c, 0, sizeof *c);
    const struct hd_capture_board *k = &b->capture;
    c->channels = k->channels;
    c->rate_hz = k->rate_hz;
    c->frame_bytes = (size_t)k->channels * (k->format == HD_FMT_S16_LE ? 2 : 4);
    int rc = lconf ? snd_pcm_open_lconf(&c->pcm, k->device, SND_PCM_STREAM_CAPTURE, SND_PCM_NONBLOCK, lconf)
                   : snd_pcm_open(&c->pcm, k->device, SND_PCM_STREAM_CAPTURE, SND_PCM_NONBLOCK);
    if (rc < 0) {
        snprintf(err, HD_ERR_MAX, "cannot open ALSA capture device '%s' ([capture] device in %s): %s%s", k->device,
                 b->path, snd_strerror(rc), rc == -EBUSY ? " (another program is using it)" : "");
        c->pcm = NULL;
        return rc;
    }
    snd_pcm_hw_params_t *hw;
    snd_pcm_sw_params_t *sw;
    snd_pcm_hw_params_alloca(&hw);
    snd_pcm_sw_params_alloca(&sw);
    const char *what = "";
    unsigned rate = k->rate_hz;
    snd_pcm_uframes_t period = period_frames, buffer = buffer_frames;
    snd_pcm_format_t fmt = k->format == HD_FMT_S16_LE ? SND_PCM_FORMAT_S16_LE : SND_PCM_FORMAT_S32_LE;
    if ((rc = snd_pcm_hw_params_any(c->pcm, hw)) < 0)
        what = "hw_params_any";
    else if ((rc = snd_pcm_hw_params_set_rate_resample(c->pcm, hw, 0)) < 0)
        what = "rate_resample off";
    else if ((rc = snd_pcm_hw_params_set_access(c->pcm, hw, SND_PCM_ACCESS_RW_INTERLEAVED)) < 0)
        what = "interleaved access";
    else if ((rc = snd_pcm_hw_params_set_format(c->pcm, hw, fmt)) < 0)
        what = "[capture] format";
    else if ((rc = snd_pcm_hw_params_set_channels(c->pcm, hw, k->channels)) < 0)
        what = "[capture] channels";
    else if ((rc = snd_pcm_hw_params_set_rate(c->pcm, hw, rate, 0)) < 0)
        what = "[capture] rate_hz";
    else if ((rc = snd_pcm_hw_params_set_period_size_near(c->pcm, hw, &period, NULL)) < 0)
        what = "period size";
    else if ((rc = snd_pcm_hw_params_set_buffer_size_near(c->pcm, hw, &buffer)) < 0)
        what = "buffer size";
    else if ((rc = snd_pcm_hw_params(c->pcm, hw)) < 0)
        what = "hw_params";
    else if ((rc = snd_pcm_sw_params_current(c->pcm, sw)) < 0)
        what = "sw_params_current";
    else if ((rc = snd_pcm_sw_params_set_avail_min(c->pcm, sw, 1)) < 0)
        what = "avail_min";
    else if ((rc = snd_pcm_sw_params(c->pcm, sw)) < 0)
        what = "sw_params";
    if (rc < 0) {
        snprintf(err, HD_ERR_MAX, "ALSA capture device '%s' ([capture] in %s) refused %s: %s", k->device, b->path, what,
                 snd_strerror(rc));
        hd_capture_close(c);
        return rc;
    }
    snd_pcm_hw_params_get_period_size(hw, &c->period_frames, NULL);
    snd_pcm_hw_params_get_buffer_size(hw, &c->buffer_frames);
    return 0;
}

void hd_capture_close(struct hd_capture *c)
{
    if (c->pcm) {
        snd_pcm_drop(c->pcm);
        snd_pcm_close(c->pcm);
    }
    memset(c, 0, sizeof *c);
}

/* ---- libasound's messages ---- */

static char lib_first[512];
static atomic_ulong lib_count; /* messages since the last take */
static atomic_int lib_slot;    /* 0 free, 1 being written, 2 holds the first message */

static void lib_message(const char *file, int line, const char *function, int err, const char *fmt, ...)
{
    (void)file;
    (void)line;
    atomic_fetch_add(&lib_count, 1);
    int expected = 0;
    if (!atomic_compare_exchange_strong(&lib_slot, &expected, 1))
        return; /* a first message is already kept */
    int n = snprintf(lib_first, sizeof lib_first, "%s: ", function ? function : "?");
    va_list ap;
    va_start(ap, fmt);
    if (n > 0 && (size_t)n < sizeof lib_first)
        n += vsnprintf(lib_first + n, sizeof lib_first - (size_t)n, fmt, ap);
    va_end(ap);
    if (err && n > 0 && (size_t)n < sizeof lib_first)
        snprintf(lib_first + n, sizeof lib_first - (size_t)n, ": %s", snd_strerror(err));
    atomic_store(&lib_slot, 2);
}

void hd_audio_lib_messages_capture(void) { snd_lib_error_set_handler(lib_message); }

unsigned long hd_audio_lib_messages_take(char *first, size_t cap)
{
    if (cap)
        first[0] = '\0';
    if (atomic_load(&lib_slot) != 2)
        return atomic_load(&lib_slot) == 0 ? atomic_exchange(&lib_count, 0) : 0;
    snprintf(first, cap, "%s", lib_first);
    unsigned long n = atomic_exchange(&lib_count, 0);
    atomic_store(&lib_slot, 0);
    return n;
}

/* ---- when a failing device is a failed one ---- */

enum hd_audio_verdict hd_audio_health_write(struct hd_audio_health *h, int write_rc, uint64_t now_ns)
{
    if (h->stretch_start_ns && now_ns - h->last_error_ns > HD_AUDIO_ERROR_GAP_NS)
        h->stretch_start_ns = 0; /* a second without errors: the stretch is over */
    if (write_rc >= 0)
        return h->stretch_start_ns ? HD_AUDIO_FAILING : HD_AUDIO_OK;
    if (!h->stretch_start_ns)
        h->stretch_start_ns = now_ns ? now_ns : 1;
    h->last_error_ns = now_ns;
    return now_ns - h->stretch_start_ns >= HD_AUDIO_GIVE_UP_NS ? HD_AUDIO_GAVE_UP : HD_AUDIO_FAILING;
}

enum hd_audio_verdict hd_audio_health_pace(uint64_t written, uint64_t start_ns, uint64_t now_ns, uint32_t rate_hz,
                                           uint64_t buffer_frames)
{
    const uint64_t elapsed_ns = now_ns > start_ns ? now_ns - start_ns : 0;
    /* 5 % over the elapsed time: a real device's clock runs a few ppm off
     * CLOCK_MONOTONIC, which over days adds up to more than any fixed slack. */
    const double can_take =
        ((double)elapsed_ns * 1.05 + (double)HD_AUDIO_AHEAD_NS) * 1e-9 * rate_hz + (double)buffer_frames;
    return (double)written > can_take ? HD_AUDIO_UNPACED : HD_AUDIO_OK;
}
