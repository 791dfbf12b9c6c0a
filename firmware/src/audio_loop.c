/* audio_loop.c - the audio thread and the scripted run (see audio_loop.h). */
#define _GNU_SOURCE
#include "audio_loop.h"

#include "log.h"

#include <errno.h>
#include <poll.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

static void publish_audio_counters(struct hd_audio_loop *l)
{
    struct hd_engine_stats *s = &l->engine->stats;
    atomic_store_explicit(&s->xruns, l->audio->xruns + l->audio->suspends, memory_order_relaxed);
    atomic_store_explicit(&s->write_errors, l->audio->errors, memory_order_relaxed);
    atomic_store_explicit(&s->rewind_error, l->audio->rewind_error, memory_order_relaxed);
}

/* One period: render, hand to ALSA, note the latency. */
static int audio_step(struct hd_audio_loop *l)
{
    const uint32_t frames = (uint32_t)l->audio->period_frames;
    hd_engine_period(l->engine, l->render_buf, frames);
    int rc = hd_audio_write(l->audio, l->render_buf, frames);
    hd_engine_written(l->engine, hd_now_ns());
    publish_audio_counters(l);
    return rc;
}

/* A trigger woke the audio thread: answer it at once. The queued frames the
 * device has not started to read (all but rewind_margin of them) are taken
 * back and rendered again, the new voice starting at the first of them, and
 * written in their place. Nothing to rewind (or a PCM that cannot): the
 * trigger waits in the ring for the next period, as without rewinding. */
static void trigger_step(struct hd_audio_loop *l)
{
    struct hd_engine *e = l->engine;
    struct hd_audio *a = l->audio;
    if (!a->rewind || !hd_engine_pending(e))
        return;
    uint64_t limit = hd_engine_rewindable(e);
    snd_pcm_uframes_t n = hd_audio_rewind(a, limit < a->buffer_frames ? limit : a->buffer_frames, hd_now_ns());
    if (n > 0) {
        hd_engine_rewind(e, n);
        while (n > 0) {
            uint32_t chunk = n < a->period_frames ? (uint32_t)n : (uint32_t)a->period_frames;
            hd_engine_period(e, l->render_buf, chunk);
            int rc = hd_audio_write(a, l->render_buf, chunk);
            hd_engine_written(e, hd_now_ns());
            if (rc < 0)
                break; /* counted; the period clock carries on */
            n -= chunk;
        }
    }
    publish_audio_counters(l);
}

static void drain_fd(int fd)
{
    uint64_t v;
    if (read(fd, &v, sizeof v) < 0) {
        /* EAGAIN: nothing to drain; nothing else can fail on an eventfd/timerfd */
    }
}

void *hd_audio_loop_run(void *arg)
{
    struct hd_audio_loop *l = arg;
    const uint64_t period_ns = (uint64_t)l->audio->period_frames * 1000000000u / l->audio->rate_hz;
    struct pollfd pfd[2 + HD_AUDIO_MAX_PFDS];
    nfds_t nfds = 0;
    pfd[nfds++] = (struct pollfd){.fd = l->trigger_efd, .events = POLLIN};
    if (l->clock_paced) {
        pfd[nfds++] = (struct pollfd){.fd = l->timer_fd, .events = POLLIN};
    } else {
        for (int i = 0; i < l->alsa_pfd_count; i++)
            pfd[nfds++] = l->alsa_pfd[i];
    }
    struct hd_audio_health health = {0};
    while (atomic_load_explicit(&l->running, memory_order_relaxed)) {
        /* Sleep until a trigger arrives or a period is due: the device has
         * room (device pacing), or the emulated device has played a period
         * (clock pacing: the file/null plugins never block). A period is
         * rendered just before it is written, with the freshest triggers. */
        uint64_t due_ns = 0;
        if (l->clock_paced) {
            due_ns = hd_audio_clock_due_ns(l->audio);
            struct itimerspec its = {.it_value = {(time_t)(due_ns / 1000000000u), (long)(due_ns % 1000000000u)}};
            timerfd_settime(l->timer_fd, TFD_TIMER_ABSTIME, &its, NULL);
        }
        for (nfds_t i = 0; i < nfds; i++)
            pfd[i].revents = 0;
        if (poll(pfd, nfds, 100) < 0)
            continue; /* EINTR; re-check running */
        if (pfd[0].revents & POLLIN) {
            drain_fd(l->trigger_efd);
            trigger_step(l);
        }
        int due;
        if (l->clock_paced) {
            if (pfd[1].revents & POLLIN)
                drain_fd(l->timer_fd);
            due = hd_now_ns() >= due_ns;
        } else {
            due = hd_audio_poll_ready(l->audio, pfd + 1, l->alsa_pfd_count) != 0; /* room, or an xrun to recover */
        }
        if (!due)
            continue;
        const int rc = audio_step(l);
        const uint64_t now = hd_now_ns();
        enum hd_audio_verdict v = hd_audio_health_write(&health, rc, now);
        if (v == HD_AUDIO_OK && !l->clock_paced)
            v = hd_audio_health_pace(l->audio->written, l->audio->start_ns, now, l->audio->rate_hz,
                                     l->audio->buffer_frames);
        if (v == HD_AUDIO_GAVE_UP || v == HD_AUDIO_UNPACED) {
            /* The main thread logs it and ends the daemon (non-zero exit). */
            atomic_store(&l->failed, (int)v);
            break;
        }
        if (rc < 0) {
            /* Counted in write_errors and logged by the main thread; back off
             * one period so a dead device does not spin the CPU. */
            struct timespec ts = {0, (long)period_ns};
            clock_nanosleep(CLOCK_MONOTONIC, 0, &ts, NULL);
        }
    }
    return NULL;
}

int hd_audio_loop_script(struct hd_audio_loop *l, const struct hd_script *s, unsigned tail_frames, const char *device)
{
    struct hd_engine *e = l->engine;
    long primed = hd_audio_prime(l->audio);
    if (primed < 0) {
        hd_log(LOG_ERR, "priming ALSA: %s", snd_strerror((int)primed));
        return 1;
    }
    hd_engine_start_at(e, (uint64_t)primed, 0); /* unpaced: no rewinds, sample-exact starts */
    size_t next = 0;
    uint64_t tail = tail_frames;
    int rc = 0;
    while (next < s->count || !hd_engine_idle(e) || tail > 0) {
        while (next < s->count && (uint64_t)s->events[next].frame <= hd_engine_frame(e)) {
            struct hd_event ev = s->events[next++];
            ev.t_ns = hd_now_ns();
            hd_spsc_push(&e->ring, &ev);
        }
        int busy = next < s->count || !hd_engine_idle(e);
        if (!busy)
            tail = tail > l->audio->period_frames ? tail - l->audio->period_frames : 0;
        int err = audio_step(l);
        if (err < 0) {
            /* Unpaced runs feed files and tests: the first failure ends the run. */
            hd_log(LOG_ERR,
                   "writing to ALSA device '%s' failed at frame %llu: %s (host-sim: does the WAV's folder exist?)",
                   device, (unsigned long long)hd_engine_frame(e), snd_strerror(err));
            rc = 1;
            break;
        }
    }
    hd_log(LOG_INFO,
           "script done: %llu frames written, %llu voices (%llu lowered, %llu skipped by the exciters' "
           "ratings)",
           (unsigned long long)hd_engine_frame(e), (unsigned long long)atomic_load(&e->stats.voices_started),
           (unsigned long long)atomic_load(&e->stats.voices_attenuated),
           (unsigned long long)atomic_load(&e->stats.voices_skipped));
    return rc;
}
