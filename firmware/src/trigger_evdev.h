/* trigger_evdev.h - thin libevdev shim for a touchscreen: find and open the
 * board's [touch] device, build the panel -> plate map from its axis ranges
 * or the board's calibration points, read events (SYN_DROPPED resync through
 * libevdev's sync mode) into the touch logic (touch.c), and notice a device
 * that goes away. */
#ifndef HD_TRIGGER_EVDEV_H
#define HD_TRIGGER_EVDEV_H

#include "board.h"
#include "hd_defs.h"
#include "touch.h"

struct libevdev;

struct hd_evdev {
    struct libevdev *dev;   /* NULL while closed */
    int fd;                 /* -1 while closed */
    char path[HD_PATH_MAX]; /* the node opened (or last opened) */
    char name[256];         /* the device's name */
    const struct hd_touch_board *cfg;
    const char *override_path; /* --touch-device, or NULL */
};

/* Open the device ([touch] device or name, or override_path) and initialize
 * the touch logic t with the map and the table's foci (ids and positions,
 * focus_xy_m as x0, y0, x1, y1, ...). One-line error naming the device and
 * the board file. Returns 0 or -errno. */
int hd_evdev_open(struct hd_evdev *e, const struct hd_touch_board *cfg, const char *board_path,
                  const char *override_path, struct hd_touch *t, uint32_t focus_count, const uint32_t *focus_id,
                  const double *focus_xy_m, char err[HD_ERR_MAX]);

/* Open the same device again after it went away (the touch logic keeps its
 * map and foci; its contacts were ended by hd_touch_lost). Returns 0 or -errno. */
int hd_evdev_reopen(struct hd_evdev *e, struct hd_touch *t);

/* Read every pending event into t; each trigger it yields goes to push.
 * Returns 0, or -errno when the device is gone or failed (then call
 * hd_evdev_close and hd_touch_lost; the caller logs). */
int hd_evdev_read(struct hd_evdev *e, struct hd_touch *t, void (*push)(void *ctx, const struct hd_event *ev),
                  void *ctx);

void hd_evdev_close(struct hd_evdev *e);

#endif
