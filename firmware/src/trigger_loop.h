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

struct hd_trigger_loop {
    int stop_fd;
    int host_fd;                   /* -1: none */
    const char *host_name;         /* for messages */
    struct hd_gpio *gpio;          /* NULL: no GPIO lines */
    struct hd_trigger *trigger;
    struct hd_evdev *evdev;        /* NULL: no touchscreen */
    struct hd_touch *touch;
    void (*push)(void *ctx, const struct hd_event *ev);
    void *push_ctx;
    struct hd_line_health health;
};

/* pthread entry point; arg is a struct hd_trigger_loop. */
void *hd_trigger_loop_run(void *arg);

#endif
