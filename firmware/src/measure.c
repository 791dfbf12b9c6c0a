/* measure.c - hapticd --measure (measure.h). */
#define _GNU_SOURCE
#include "measure.h"

#include "audio_alsa.h"
#include "log.h"
#include "protect.h"

#include <errno.h>
#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define STALL_NS 3000000000ull /* no frame moved either way for this long: the devices stalled */
#define CHUNK 64u              /* frames per step of the heat model */

int hd_measure_check_plan(const struct hd_wav *plan, const char *plan_path, const struct hd_board *b,
                          char err[HD_ERR_MAX])
{
    if (plan->rate_hz != b->rate_hz) {
        snprintf(err, HD_ERR_MAX, "%s: plan at %u Hz, the board plays %u Hz ([alsa] rate_hz in %s)", plan_path,
                 plan->rate_hz, b->rate_hz, b->path);
        return -EINVAL;
    }
    if (plan->channels != b->map_count) {
        snprintf(err, HD_ERR_MAX, "%s: plan of %u channels, the board drives %u exciters ([alsa] channel_map in %s)",
                 plan_path, plan->channels, b->map_count, b->path);
        return -EINVAL;
    }
    const size_t n = (size_t)plan->frames * plan->channels;
    int32_t peak = 0;
    for (size_t i = 0; i < n; i++) {
        const int32_t s = plan->samples[i];
        if (b->format == HD_FMT_S16_LE && (s & 0xffff)) {
            snprintf(err, HD_ERR_MAX,
                     "%s: %u-bit samples (frame %zu channel %zu) that the board's S16_LE ([alsa] format in %s) "
                     "would round: write the plan in 16 bits",
                     plan_path, plan->bits, i / plan->channels, i % plan->channels, b->path);
            return -EINVAL;
        }
        const int32_t a = s == INT32_MIN ? INT32_MAX : abs(s);
        if (a > peak)
            peak = a;
    }
    /* Full scale of the plan = a table's full scale: gain 1. */
    const double peak_fs = (double)peak / 2147483648.0;
    if (peak_fs > b->gain_limit * (1.0 + 1e-12)) {
        snprintf(err, HD_ERR_MAX,
                 "%s: peak %.4f of full scale above [mixer] gain_limit %.4f in %s: hapticd does not scale a plan; "
                 "lower its level (calibgen measure-plan --level-dbfs)",
                 plan_path, peak_fs, b->gain_limit, b->path);
        return -EINVAL;
    }
    return 0;
}

int hd_measure_check_power(const struct hd_wav *plan, const char *plan_path, const struct hd_board *b, double *heat_w,
                           double *rated_w, unsigned *exciter, char err[HD_ERR_MAX])
{
    struct hd_exciter_rating rating[HD_MAX_CHANNELS], on_device[HD_MAX_CHANNELS];
    if (!hd_board_exciter_ratings(b, rating, b->map_count))
        return 0;
    memset(on_device, 0, sizeof on_device);
    for (uint32_t k = 0; k < b->map_count; k++)
        on_device[b->channel_map[k]] = rating[k];
    struct hd_protect pr;
    if (hd_protect_init(&pr, b->channels, on_device, b->amp_full_scale_v, b->rate_hz) != 0) {
        snprintf(err, HD_ERR_MAX, "%s: [exciters] ratings that cannot be enforced", b->path);
        return -EINVAL;
    }
    int64_t acc[CHUNK * HD_MAX_CHANNELS];
    double peak[HD_MAX_CHANNELS] = {0};
    double peak_t[HD_MAX_CHANNELS] = {0};
    for (uint64_t at = 0; at < plan->frames; at += CHUNK) {
        const uint32_t n = plan->frames - at < CHUNK ? (uint32_t)(plan->frames - at) : CHUNK;
        memset(acc, 0, sizeof acc);
        for (uint32_t f = 0; f < n; f++)
            for (uint32_t k = 0; k < b->map_count; k++)
                /* table counts (full scale 32767 ~ 2^15) in Q30: the 32-bit scale sample * 2^14 */
                acc[(size_t)f * b->channels + b->channel_map[k]] =
                    (int64_t)plan->samples[(size_t)(at + f) * plan->channels + k] * 16384;
        const uint64_t end_ns = (uint64_t)((double)(at + n) * 1e9 / b->rate_hz);
        hd_protect_played(&pr, acc, n, b->channels, end_ns);
        for (uint32_t k = 0; k < b->map_count; k++) {
            const double h = hd_protect_heat_w(&pr, b->channel_map[k], end_ns);
            if (h > peak[k]) {
                peak[k] = h;
                peak_t[k] = (double)(at + n) / b->rate_hz;
            }
        }
    }
    unsigned hot = 0;
    double worst = -1;
    for (uint32_t k = 0; k < b->map_count; k++) {
        const double r = rating[k].rated_power_w;
        if (r <= 0)
            continue;
        if (peak[k] > r) {
            snprintf(err, HD_ERR_MAX,
                     "%s: exciter %u would heat to %.3g W at %.2f s, above its %.3g W rating ([exciters] "
                     "rated_power_w in %s): hapticd does not scale a plan; lower its level or shorten its sweeps",
                     plan_path, k, peak[k], peak_t[k], r, b->path);
            return -EINVAL;
        }
        if (peak[k] / r > worst) {
            worst = peak[k] / r;
            hot = k;
        }
    }
    *exciter = hot;
    *heat_w = peak[hot];
    *rated_w = rating[hot].rated_power_w;
    return 1;
}

void hd_measure_render(const struct hd_wav *plan, const struct hd_board *b, uint64_t lead, uint64_t from,
                       uint32_t frames, void *out)
{
    const int s16 = b->format == HD_FMT_S16_LE;
    memset(out, 0, (size_t)frames * b->channels * (s16 ? 2 : 4));
    for (uint32_t n = 0; n < frames; n++) {
        const uint64_t t = from + n;
        if (t < lead || t - lead >= plan->frames)
            continue;
        const int32_t *src = &plan->samples[(size_t)(t - lead) * plan->channels];
        for (uint32_t k = 0; k < b->map_count; k++) {
            const size_t at = (size_t)n * b->channels + b->channel_map[k];
            if (s16)
                ((int16_t *)out)[at] = (int16_t)(src[k] >> 16);
            else
                ((int32_t *)out)[at] = src[k];
        }
    }
}

/* ---- the run ---- */

static uint64_t now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

/* One hapticd line: ours, with libasound's first word on it. */
static void log_err(const char *msg)
{
    char lib[512];
    if (hd_audio_lib_messages_take(lib, sizeof lib) && lib[0])
        hd_log(LOG_ERR, "%s (libasound: %s)", msg, lib);
    else
        hd_log(LOG_ERR, "%s", msg);
}

struct run {
    const struct hd_board *b;
    const struct hd_wav *plan;
    struct hd_audio *a;
    struct hd_capture *c;
    uint64_t lead;      /* playback frame of plan frame 0 (the pre-fill) */
    uint64_t skip;      /* capture frame of plan frame 0: lead + offset */
    uint64_t written;   /* playback frames written */
    uint64_t captured;  /* capture frames read */
    int32_t *rec;       /* plan frames x capture channels, 32-bit scale */
    void *play_buf;     /* one period in the device format */
    uint32_t play_left; /* frames of play_buf not written yet */
    void *cap_buf;      /* one capture period */
};

/* Capture frames read -> the recording (those in [skip, skip + plan frames)). */
static void keep(struct run *r, uint32_t frames)
{
    const int s16 = r->b->capture.format == HD_FMT_S16_LE;
    for (uint32_t n = 0; n < frames; n++) {
        const uint64_t i = r->captured + n;
        if (i < r->skip || i - r->skip >= r->plan->frames)
            continue;
        int32_t *dst = &r->rec[(size_t)(i - r->skip) * r->c->channels];
        for (uint32_t ch = 0; ch < r->c->channels; ch++) {
            const size_t at = (size_t)n * r->c->channels + ch;
            dst[ch] = s16 ? (int32_t)((uint32_t)((int16_t *)r->cap_buf)[at] << 16) : ((int32_t *)r->cap_buf)[at];
        }
    }
    r->captured += frames;
}

/* Write what is left of the current period, rendering the next one when
 * empty. >0: frames written, 0: no room, <0: error. */
static long play_some(struct run *r)
{
    const uint32_t period = (uint32_t)r->a->period_frames;
    if (!r->play_left) {
        hd_measure_render(r->plan, r->b, r->lead, r->written, period, r->play_buf);
        r->play_left = period;
    }
    const size_t off = (size_t)(period - r->play_left) * r->a->frame_bytes;
    snd_pcm_sframes_t w = snd_pcm_writei(r->a->pcm, (const uint8_t *)r->play_buf + off, r->play_left);
    if (w == -EAGAIN)
        return 0;
    if (w < 0)
        return (long)w;
    r->play_left -= (uint32_t)w;
    r->written += (uint64_t)w;
    return (long)w;
}

static long capture_some(struct run *r, snd_pcm_uframes_t max)
{
    snd_pcm_uframes_t want = r->c->period_frames < max ? r->c->period_frames : max;
    if (!want)
        return 0;
    memset(r->cap_buf, 0, want * r->c->frame_bytes);
    snd_pcm_sframes_t got = snd_pcm_readi(r->c->pcm, r->cap_buf, want);
    if (got == -EAGAIN)
        return 0;
    if (got < 0)
        return (long)got;
    keep(r, (uint32_t)got);
    return (long)got;
}

static int xfer_error(struct run *r, const char *dir, long rc, const char *device, char err[HD_ERR_MAX])
{
    snprintf(err, HD_ERR_MAX, "%s of '%s' failed at frame %llu: %s%s: no recording written", dir, device,
             (unsigned long long)(dir[0] == 'p' ? r->written : r->captured), snd_strerror((int)rc),
             rc == -EPIPE ? (dir[0] == 'p' ? " (underrun: the plan did not play continuously)"
                                           : " (overrun: the recording would have a gap)")
                          : "");
    return -1;
}

/* Device pacing: both PCMs non-blocking, polled together. */
static int run_device(struct run *r, const char *play_dev, char err[HD_ERR_MAX])
{
    const uint64_t need = r->skip + r->plan->frames;
    struct pollfd pfd[2 * HD_AUDIO_MAX_PFDS];
    int np = snd_pcm_poll_descriptors(r->a->pcm, pfd, HD_AUDIO_MAX_PFDS);
    int nc = snd_pcm_poll_descriptors(r->c->pcm, pfd + (np > 0 ? np : 0), HD_AUDIO_MAX_PFDS);
    if (np <= 0 || nc <= 0) {
        snprintf(err, HD_ERR_MAX, "ALSA poll descriptors: %s", snd_strerror(np <= 0 ? np : nc));
        return -1;
    }
    uint64_t last = now_ns();
    while (r->captured < need) {
        long w = play_some(r);
        if (w < 0)
            return xfer_error(r, "playback", w, play_dev, err);
        long c = capture_some(r, (snd_pcm_uframes_t)(need - r->captured));
        if (c < 0)
            return xfer_error(r, "capture", c, r->b->capture.device, err);
        const uint64_t t = now_ns();
        if (w > 0 || c > 0) {
            last = t;
            continue;
        }
        if (t - last > STALL_NS) {
            snprintf(err, HD_ERR_MAX,
                     "ALSA devices '%s' and '%s' moved no frame for %.0f s (%llu played, %llu captured): no "
                     "recording written",
                     play_dev, r->b->capture.device, STALL_NS * 1e-9, (unsigned long long)r->written,
                     (unsigned long long)r->captured);
            return -1;
        }
        poll(pfd, (nfds_t)(np + nc), 100);
    }
    return 0;
}

/* Clock pacing: an emulated device with the playback's buffer; capture
 * frame i is there once playback frame i + buffer has been written. */
static int run_clock(struct run *r, const char *play_dev, char err[HD_ERR_MAX])
{
    const uint64_t need = r->skip + r->plan->frames;
    const uint64_t buffer = r->a->buffer_frames;
    while (r->captured < need) {
        while (r->written < r->captured + buffer + r->c->period_frames) {
            long w = play_some(r);
            if (w < 0)
                return xfer_error(r, "playback", w, play_dev, err);
            if (w == 0) {
                snprintf(err, HD_ERR_MAX, "ALSA device '%s' ([alsa] pacing = clock) took no frame", play_dev);
                return -1;
            }
        }
        uint64_t ready = r->written - buffer;
        while (r->captured < ready && r->captured < need) {
            uint64_t max = ready - r->captured;
            if (max > need - r->captured)
                max = need - r->captured;
            long c = capture_some(r, (snd_pcm_uframes_t)max);
            if (c < 0)
                return xfer_error(r, "capture", c, r->b->capture.device, err);
            if (c == 0) {
                snprintf(err, HD_ERR_MAX, "ALSA capture device '%s' ([alsa] pacing = clock) gave no frame",
                         r->b->capture.device);
                return -1;
            }
        }
    }
    return 0;
}

int hd_measure_run(const struct hd_board *b, const char *plan_path, const char *rec_path, const char *alsa_device)
{
    char err[HD_ERR_MAX];
    const struct hd_capture_board *k = &b->capture;
    if (!k->enabled) {
        hd_log(LOG_ERR, "%s: no [capture] section: --measure records the board's capture device ([capture] device)",
               b->path);
        return 1;
    }
    struct hd_wav plan;
    if (hd_wav_read(plan_path, &plan, err) != 0 || hd_measure_check_plan(&plan, plan_path, b, err) != 0) {
        hd_log(LOG_ERR, "%s", err);
        hd_wav_free(&plan);
        return 1;
    }
    double heat = 0, rated = 0;
    unsigned hot = 0;
    int power = hd_measure_check_power(&plan, plan_path, b, &heat, &rated, &hot, err);
    if (power < 0) {
        hd_log(LOG_ERR, "%s", err);
        hd_wav_free(&plan);
        return 1;
    }
    struct hd_wav_out out;
    if (hd_wav_out_open(&out, rec_path, err) != 0) {
        hd_log(LOG_ERR, "%s", err);
        hd_wav_free(&plan);
        return 1;
    }
    const char *play_dev = alsa_device ? alsa_device : k->playback_device[0] ? k->playback_device : b->alsa_device;
    struct hd_board pb = *b; /* the playback as tables play, on play_dev */
    struct hd_audio a;
    struct hd_capture c = {0};
    struct run r = {.b = b, .plan = &plan, .a = &a, .c = &c};
    int status = 1;
    /* The playback first: its hw_params may create what the capture reads (host-sim's loopback file). */
    if (hd_audio_open(&a, &pb, play_dev, err) != 0) {
        log_err(err);
        goto out;
    }
    if (hd_capture_open(&c, b, a.lconf, a.period_frames, a.buffer_frames * 4, err) != 0) {
        log_err(err);
        goto out;
    }
    const int clock = b->pacing == HD_PACE_CLOCK;
    int rc;
    if (!clock && (rc = snd_pcm_link(a.pcm, c.pcm)) < 0) {
        snprintf(err, HD_ERR_MAX,
                 "cannot link capture '%s' to playback '%s' (snd_pcm_link: %s): --measure needs both on one card, "
                 "started together ([capture] device in %s)",
                 k->device, play_dev, snd_strerror(rc), b->path);
        log_err(err);
        goto out;
    }
    r.rec = calloc((size_t)plan.frames * c.channels, sizeof *r.rec);
    r.play_buf = malloc(a.period_frames * a.frame_bytes);
    r.cap_buf = malloc(c.period_frames * c.frame_bytes);
    if (!r.rec || !r.play_buf || !r.cap_buf) {
        hd_log(LOG_ERR, "out of memory for a recording of %llu frames", (unsigned long long)plan.frames);
        goto out;
    }
    if (!clock && (rc = snd_pcm_nonblock(a.pcm, 1)) < 0) {
        snprintf(err, HD_ERR_MAX, "ALSA device '%s': cannot set non-blocking mode: %s", play_dev, snd_strerror(rc));
        log_err(err);
        goto out;
    }
    /* Said once the devices are open: a refusal stays one line. */
    if (power == 0)
        hd_log(LOG_WARNING, "%s has no [exciters] ratings: the plan's power is not checked", b->path);
    else
        hd_log(LOG_INFO, "exciters: the plan heats exciter %u most, to %.3g W of its %.3g W rating", hot, heat, rated);
    hd_log(LOG_INFO,
           "measure: %s (%llu frames, %u ch, %u bit) on '%s' (%s, period %lu, buffer %lu), recording '%s' (%u ch "
           "%s) %s; plan frame 0 = capture frame %lu (pre-fill) + %u ([capture] offset_frames)",
           plan_path, (unsigned long long)plan.frames, plan.channels, plan.bits, play_dev, hd_format_name(b->format),
           (unsigned long)a.period_frames, (unsigned long)a.buffer_frames, k->device, c.channels,
           hd_format_name(k->format), clock ? "clock-paced (emulated device)" : "linked (snd_pcm_link)",
           (unsigned long)a.buffer_frames, k->offset_frames);
    long primed = hd_audio_prime(&a); /* the start threshold (the buffer) starts both */
    if (primed < 0) {
        snprintf(err, HD_ERR_MAX, "priming ALSA device '%s': %s", play_dev, snd_strerror((int)primed));
        log_err(err);
        goto out;
    }
    r.lead = r.written = (uint64_t)primed;
    r.skip = r.lead + k->offset_frames;
    if ((clock ? run_clock(&r, play_dev, err) : run_device(&r, play_dev, err)) != 0) {
        log_err(err);
        goto out;
    }
    hd_capture_close(&c);
    hd_audio_close(&a, 0);
    if (hd_wav_out_commit(&out, c.channels ? c.channels : k->channels, k->rate_hz, k->format == HD_FMT_S16_LE ? 16 : 32,
                          r.rec, plan.frames, err) != 0) {
        hd_log(LOG_ERR, "%s", err);
        goto out;
    }
    hd_log(LOG_INFO, "measure: recorded %llu frames x %u channels to %s", (unsigned long long)plan.frames, k->channels,
           rec_path);
    status = 0;
out:
    if (status != 0)
        hd_wav_out_abort(&out);
    hd_capture_close(&c);
    hd_audio_close(&a, 0);
    free(r.rec);
    free(r.play_buf);
    free(r.cap_buf);
    hd_wav_free(&plan);
    return status;
}
