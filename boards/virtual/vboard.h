/* vboard.h - the virtual board's test driver: it runs inside the guest
 * (Debian's kernel under qemu) next to hapticd, records the capture side of
 * snd-aloop, injects triggers (host FIFO) and touches (uinput), and checks
 * the recording against the table.
 *
 * Every check prints one line "vboard: PASS name: detail" or
 * "vboard: FAIL name: detail"; scripts/virtual-board counts them. */
#ifndef VBOARD_H
#define VBOARD_H

#include <haptic_table.h>

#include <alsa/asoundlib.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

/* ---- checks (vboard_check.c) ---- */

void vb_result(int ok, const char *name, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
unsigned vb_failed(void);

/* The synthetic table: VB_FOCI foci of VB_SAMPLES frames on 8 channels at
 * 48 kHz, independent uniform samples (uncorrelated foci, so two at once get
 * g = 1/sqrt(2) within a few 1e-3) at an amplitude the peak limit never binds. */
#define VB_FOCI 4u
#define VB_SAMPLES 2400u /* 50 ms */
#define VB_AMPLITUDE 8000
int vb_make_table(const char *path);

/* What one trigger should have produced: the foci (table indices) of one
 * voice, and where in the recording to look for it. */
struct vb_expect {
    const char *name;
    uint32_t index[2];
    unsigned count;
    uint64_t t_ns;    /* CLOCK_MONOTONIC of the trigger (FIFO write or kernel input event) */
    double latency_s; /* out: voice start on the capture's clock minus t_ns */
    int found;        /* out */
};

struct vb_capture;
/* Look for the voice after e->t_ns and before `until_ns` (the next trigger)
 * and compare it sample by sample with the table; one PASS/FAIL line. One
 * run of silence inside the voice is allowed if at least `underrun_frames`
 * long (hapticd primes its whole buffer with silence after an underrun). */
void vb_check_voice(const struct vb_capture *cap, const haptic_table *t, struct vb_expect *e, uint64_t until_ns,
                    size_t underrun_frames);

/* ---- capture (vboard_capture.c) ---- */

#define VB_MAX_SEGMENTS 64

/* A run of frames captured without an overrun; frame i of the recording
 * (segment start <= i) was captured at t0_ns + (i - start) / rate on the
 * kernel's CLOCK_MONOTONIC. */
struct vb_segment {
    size_t start;
    double t0_ns;
};

struct vb_capture {
    snd_pcm_t *pcm;
    unsigned channels, rate_hz;
    snd_pcm_uframes_t period_frames, buffer_frames;
    int32_t *frames; /* [frame][channel], S32 as played */
    size_t capacity;
    _Atomic size_t count;
    struct vb_segment segments[VB_MAX_SEGMENTS];
    _Atomic unsigned segment_count;
    _Atomic unsigned overruns;
    _Atomic int stall_ms; /* the reader sleeps this long once (an overrun on purpose) */
    _Atomic int stop;
    int error;        /* the ALSA error that ended the reader, 0 if none */
    unsigned tick_hz; /* snd-aloop's timer (the kernel's HZ); 0: unknown */
};

int vb_capture_open(struct vb_capture *c, const char *device, unsigned channels, unsigned rate_hz, double seconds);
int vb_capture_start(struct vb_capture *c); /* reader thread at SCHED_FIFO when allowed */
void vb_capture_stop(struct vb_capture *c);
void vb_capture_close(struct vb_capture *c);
/* The segment that holds the capture of time t_ns, or NULL; *frame = the index. */
const struct vb_segment *vb_capture_at(const struct vb_capture *c, uint64_t t_ns, size_t *frame);
/* Capture time of frame i (NaN if no segment holds it): its nominal time
 * t0 + i / rate, or with `delivered` the timer tick at which snd-aloop
 * handed it to the capture side (the first tick at or after its end). */
double vb_capture_time_ns(const struct vb_capture *c, size_t i, int delivered);

/* ---- touches (vboard_uinput.c) ---- */

#define VB_TOUCH_NAME "vboard-touch"
#define VB_TOUCH_X_MAX 4095
#define VB_TOUCH_Y_MAX 4095

struct vb_touch {
    int uinput_fd; /* the device we write */
    int evdev_fd;  /* its /dev/input/eventN, read back for the kernel's timestamps */
    char evdev_path[64];
};

/* A multi-touch (protocol B) panel with VB_TOUCH_X_MAX x VB_TOUCH_Y_MAX
 * resolution, INPUT_PROP_DIRECT. Returns 0 or -errno. */
int vb_touch_open(struct vb_touch *t);
void vb_touch_close(struct vb_touch *t);
/* Contacts down in one frame (one SYN_REPORT): slot k at (x[k], y[k]). */
int vb_touch_down(struct vb_touch *t, unsigned count, const int *x, const int *y);
int vb_touch_up(struct vb_touch *t, unsigned count);
/* Read back the next frame from the evdev node: the kernel's CLOCK_MONOTONIC
 * timestamp of its SYN_REPORT, and the positions of slots 0 and 1 seen in it. */
int vb_touch_read_frame(struct vb_touch *t, int timeout_ms, uint64_t *t_ns, int pos[2][2]);

uint64_t vb_now_ns(void);

#endif
