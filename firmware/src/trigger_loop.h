/* trigger_loop.h - the trigger thread: polls the board's GPIO event fds, the
 * touchscreen and the host trigger input (stdin or a FIFO), runs their events
 * through the trigger and touch logic and hands each trigger to `push` (the ring to the audio
 * thread). Ends when stop_fd becomes readable. Logs; never touches audio. */
#ifndef HD_TRIGGER_LOOP_H
#define HD_TRIGGER_LOOP_H

#include "trigger.h"
#include "touch.h"
#include "trigger_evdev.h"
#include "trigger_gpiod.h"

#include <haptic_table.h>
#include <stdatomic.h>

/* A reloaded table's foci for the touchscreen, handed from the main thread
 * (one allocation: ids and positions follow the struct). */
struct hd_touch_foci {
    uint32_t count;
    uint32_t *id;
    double *xy_m;
};

/* Main thread: the foci of table t, or NULL when out of memory. Free with free(). */
struct hd_touch_foci *hd_touch_foci_of(const haptic_table *t);

struct hd_trigger_loop {
    int stop_fd;
    int host_fd;           /* -1: none */
    const char *host_name; /* for messages */
    struct hd_gpio *gpio;  /* NULL: no GPIO lines */
    struct hd_trigger *trigger;
    struct hd_evdev *evdev; /* NULL: no touchscreen */
    struct hd_touch *touch;
    _Atomic(struct hd_touch_foci *) next_foci; /* main -> trigger thread on reload */
    void (*push)(void *ctx, const struct hd_event *ev);
    void *push_ctx;
    struct hd_line_health health;
};

/* pthread entry point; arg is a struct hd_trigger_loop. */
void *hd_trigger_loop_run(void *arg);

#endif
