/* audio_loop.h - the audio thread and the unpaced scripted run.
 *
 * Live: sleeps in poll until a trigger wakes it (eventfd) or a period is due
 * (the device's poll descriptors, or a timerfd at the emulated device's
 * deadline with clock pacing); on a trigger it rewinds the queued frames to
 * start the voice at once; on a due period it renders and writes one. Never
 * allocates, locks or logs: it reports through the engine's atomic counters.
 * Scripted: the same render and write in one thread, unpaced. */
#ifndef HD_AUDIO_LOOP_H
#define HD_AUDIO_LOOP_H

#include "audio_alsa.h"
#include "engine.h"
#include "script.h"

#include <stdatomic.h>

struct hd_audio_loop {
    struct hd_engine *engine;
    struct hd_audio *audio;
    int clock_paced;
    int trigger_efd;                           /* trigger thread -> audio thread: "an event is in the ring" */
    int timer_fd;                              /* clock pacing: the emulated device's period deadline */
    struct pollfd alsa_pfd[HD_AUDIO_MAX_PFDS]; /* device pacing */
    int alsa_pfd_count;
    void *render_buf; /* one period in the device format */
    atomic_int running;
    atomic_int failed; /* the device failed (an enum hd_audio_verdict: GAVE_UP, UNPACED); the thread ended */
};

/* pthread entry point; arg is a struct hd_audio_loop. Runs while `running`. */
void *hd_audio_loop_run(void *arg);

/* Unpaced: device frames are counted from the first frame written (the
 * pre-fill included); an event stamped F starts at the first period boundary
 * >= F that is still to be written. Runs until every event has played and
 * tail_frames more. `device` names the PCM in messages. Returns 0 or 1. */
int hd_audio_loop_script(struct hd_audio_loop *l, const struct hd_script *s, unsigned tail_frames, const char *device);

#endif
