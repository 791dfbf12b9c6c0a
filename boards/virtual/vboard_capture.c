/* vboard_capture.c - records the capture side of snd-aloop with the kernel's
 * timestamps. snd-aloop copies what the playback side queued into the
 * capture buffer as its timer advances, so the recording holds exactly the
 * frames the "DAC" played, rewrites by rewinding included. */
#define _GNU_SOURCE
#include "vboard.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static pthread_t reader;

uint64_t vb_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

int vb_capture_open(struct vb_capture *c, const char *device, unsigned channels, unsigned rate_hz, double seconds)
{
    memset(c, 0, sizeof *c);
    c->channels = channels;
    c->rate_hz = rate_hz;
    int rc = snd_pcm_open(&c->pcm, device, SND_PCM_STREAM_CAPTURE, 0);
    if (rc < 0) {
        fprintf(stderr, "vboard: capture %s: %s\n", device, snd_strerror(rc));
        return rc;
    }
    snd_pcm_hw_params_t *hw;
    snd_pcm_sw_params_t *sw;
    snd_pcm_hw_params_alloca(&hw);
    snd_pcm_sw_params_alloca(&sw);
    /* snd-aloop holds the capture side to the playback side's format, rate
     * and channels (hapticd has set them); a large buffer gives the reader
     * slack under emulation. */
    snd_pcm_uframes_t buffer = rate_hz / 5;
    if ((rc = snd_pcm_hw_params_any(c->pcm, hw)) < 0 ||
        (rc = snd_pcm_hw_params_set_access(c->pcm, hw, SND_PCM_ACCESS_RW_INTERLEAVED)) < 0 ||
        (rc = snd_pcm_hw_params_set_format(c->pcm, hw, SND_PCM_FORMAT_S32_LE)) < 0 ||
        (rc = snd_pcm_hw_params_set_channels(c->pcm, hw, channels)) < 0 ||
        (rc = snd_pcm_hw_params_set_rate(c->pcm, hw, rate_hz, 0)) < 0 ||
        (rc = snd_pcm_hw_params_set_buffer_size_near(c->pcm, hw, &buffer)) < 0 ||
        (rc = snd_pcm_hw_params(c->pcm, hw)) < 0) {
        fprintf(stderr, "vboard: capture %s hw params: %s\n", device, snd_strerror(rc));
        return rc;
    }
    snd_pcm_hw_params_get_period_size(hw, &c->period_frames, NULL);
    snd_pcm_hw_params_get_buffer_size(hw, &c->buffer_frames);
    /* Timestamps on CLOCK_MONOTONIC, the clock triggers and input events use. */
    if ((rc = snd_pcm_sw_params_current(c->pcm, sw)) < 0 ||
        (rc = snd_pcm_sw_params_set_tstamp_mode(c->pcm, sw, SND_PCM_TSTAMP_ENABLE)) < 0 ||
        (rc = snd_pcm_sw_params_set_tstamp_type(c->pcm, sw, SND_PCM_TSTAMP_TYPE_MONOTONIC)) < 0 ||
        (rc = snd_pcm_sw_params(c->pcm, sw)) < 0) {
        fprintf(stderr, "vboard: capture %s sw params: %s\n", device, snd_strerror(rc));
        return rc;
    }
    c->capacity = (size_t)(seconds * rate_hz);
    c->frames = calloc(c->capacity * channels, sizeof *c->frames);
    return c->frames ? 0 : -ENOMEM;
}

static void segment_begin(struct vb_capture *c)
{
    unsigned n = atomic_load(&c->segment_count);
    if (n == VB_MAX_SEGMENTS)
        return;
    c->segments[n] = (struct vb_segment){.start = atomic_load(&c->count), .t0_ns = INFINITY};
    atomic_store(&c->segment_count, n + 1);
}

/* The device's position lags the true time by up to one timer tick and never
 * leads it, so the smallest (timestamp - position / rate) seen is the
 * closest estimate of when frame 0 of the segment was captured. */
static void segment_update(struct vb_capture *c, size_t read_in_segment)
{
    snd_pcm_status_t *st;
    snd_pcm_status_alloca(&st);
    if (snd_pcm_status(c->pcm, st) < 0)
        return;
    snd_htimestamp_t ts;
    snd_pcm_status_get_htstamp(st, &ts);
    double pos = (double)read_in_segment + (double)snd_pcm_status_get_avail(st);
    double t0 = (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec - pos * 1e9 / c->rate_hz;
    struct vb_segment *s = &c->segments[atomic_load(&c->segment_count) - 1];
    if (t0 < s->t0_ns)
        s->t0_ns = t0;
}

static void *reader_main(void *arg)
{
    struct vb_capture *c = arg;
    size_t in_segment = 0;
    segment_begin(c);
    int rc = snd_pcm_start(c->pcm);
    while (rc >= 0 && !atomic_load(&c->stop)) {
        int stall = atomic_exchange(&c->stall_ms, 0);
        if (stall > 0) {
            struct timespec ts = {stall / 1000, (long)(stall % 1000) * 1000000};
            nanosleep(&ts, NULL);
        }
        size_t count = atomic_load(&c->count);
        snd_pcm_uframes_t want = c->period_frames;
        if (count + want > c->capacity) {
            rc = -ENOSPC;
            break;
        }
        snd_pcm_sframes_t r = snd_pcm_readi(c->pcm, c->frames + count * c->channels, want);
        if (r == -EPIPE) {
            /* Overrun: frames were lost, so the timeline restarts. */
            atomic_fetch_add(&c->overruns, 1);
            if ((rc = snd_pcm_prepare(c->pcm)) < 0)
                break;
            segment_begin(c);
            in_segment = 0;
            rc = snd_pcm_start(c->pcm);
            continue;
        }
        if (r == -EAGAIN || r == -EINTR)
            continue;
        if (r < 0) {
            rc = (int)r;
            break;
        }
        atomic_store(&c->count, count + (size_t)r);
        in_segment += (size_t)r;
        segment_update(c, in_segment);
    }
    c->error = rc < 0 && rc != -ENOSPC ? rc : 0;
    if (rc == -ENOSPC)
        fprintf(stderr, "vboard: capture buffer full, recording stopped\n");
    return NULL;
}

int vb_capture_start(struct vb_capture *c)
{
    pthread_attr_t attr;
    pthread_attr_init(&attr);
    struct sched_param sp = {.sched_priority = 70};
    pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
    pthread_attr_setschedpolicy(&attr, SCHED_FIFO);
    pthread_attr_setschedparam(&attr, &sp);
    int rc = pthread_create(&reader, &attr, reader_main, c);
    if (rc == EPERM)
        rc = pthread_create(&reader, NULL, reader_main, c);
    pthread_attr_destroy(&attr);
    return -rc;
}

void vb_capture_stop(struct vb_capture *c)
{
    atomic_store(&c->stop, 1);
    pthread_join(reader, NULL);
}

void vb_capture_close(struct vb_capture *c)
{
    if (c->pcm)
        snd_pcm_close(c->pcm);
    free(c->frames);
    memset(c, 0, sizeof *c);
}

static size_t segment_end(const struct vb_capture *c, unsigned k)
{
    return k + 1 < atomic_load(&c->segment_count) ? c->segments[k + 1].start : atomic_load(&c->count);
}

const struct vb_segment *vb_capture_at(const struct vb_capture *c, uint64_t t_ns, size_t *frame)
{
    for (unsigned k = atomic_load(&c->segment_count); k-- > 0;) {
        const struct vb_segment *s = &c->segments[k];
        if (!isfinite(s->t0_ns) || (double)t_ns < s->t0_ns)
            continue;
        double i = (double)s->start + ((double)t_ns - s->t0_ns) * c->rate_hz / 1e9;
        if (i >= (double)segment_end(c, k))
            return NULL;
        *frame = (size_t)i;
        return s;
    }
    return NULL;
}

double vb_capture_time_ns(const struct vb_capture *c, size_t i, int delivered)
{
    for (unsigned k = atomic_load(&c->segment_count); k-- > 0;) {
        const struct vb_segment *s = &c->segments[k];
        if (i < s->start || i >= segment_end(c, k))
            continue;
        double frames = (double)(i - s->start);
        if (!delivered || !c->tick_hz)
            return s->t0_ns + frames * 1e9 / c->rate_hz;
        /* snd-aloop moves floor(ticks * rate / HZ) frames after `ticks`
         * ticks since the stream started (t0). */
        return s->t0_ns + ceil((frames + 1) * c->tick_hz / c->rate_hz) * 1e9 / c->tick_hz;
    }
    return NAN;
}
