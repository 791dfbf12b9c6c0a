/* touch.h - touchscreen contacts to focus triggers (pure logic; the evdev
 * shim is trigger_evdev.c).
 *
 * Panel coordinates (ABS_MT_POSITION_X/Y, or ABS_X/Y) go through an affine
 * map to plate metres. Each contact plays its nearest focus when it comes
 * down within max_distance_m of it, and again when it moves into another
 * focus's cell: a contact holding focus c at point p switches to the nearest
 * focus n only when |p - c| > |p - n| + hysteresis_m, and lets go of c only
 * beyond max_distance_m + hysteresis_m, so jitter on a cell border or at the
 * edge of the range never re-fires. Every focus started within one input
 * frame (one SYN_REPORT) by any contact goes into ONE trigger: contacts down
 * at the same time are one voice with one energy-normalized gain.
 *
 * Multi-touch protocol B: ABS_MT_SLOT selects a slot, ABS_MT_TRACKING_ID
 * >= 0 starts a contact in it (a new id in a slot is a new contact, even
 * without a -1 between), -1 ends it. Single-touch panels: BTN_TOUCH 1/0
 * with ABS_X/Y. On an MT device the kernel's single-touch emulation is
 * ignored. SYN_DROPPED discards the frame in progress; the shim then feeds
 * the device's state again (libevdev's sync events), which is applied like
 * any frame: contacts still in their cell stay quiet, new ones fire.
 */
#ifndef HD_TOUCH_H
#define HD_TOUCH_H

#include "event.h"
#include "hd_defs.h"

#include <stdbool.h>
#include <stdint.h>

#define HD_TOUCH_SLOTS 16u /* contacts tracked at once (more slots are ignored) */
#define HD_TOUCH_MAX_FOCI 1024u

/* plate = (m[0] px + m[1] py + m[2], m[3] px + m[4] py + m[5]) in metres */
struct hd_touch_map {
    double m[6];
};

/* The affine map through three point pairs panel -> plate, each given as
 * x0, y0, x1, y1, x2, y2. Returns 0, or -EINVAL when the panel points are
 * (nearly) collinear. */
int hd_touch_map_from_points(const double *panel_xy, const double *plate_xy, struct hd_touch_map *out);
/* The panel's range [x_min, x_max] x [y_min, y_max] onto the plate rectangle
 * area = {x0, y0, x1, y1}. Returns -EINVAL for an empty range. */
int hd_touch_map_from_area(int32_t x_min, int32_t x_max, int32_t y_min, int32_t y_max, const double area[4],
                           struct hd_touch_map *out);
void hd_touch_map_apply(const struct hd_touch_map *map, double px, double py, double *x_m, double *y_m);

struct hd_touch_contact {
    int32_t tracking_id; /* -1: no contact */
    int32_t x, y;        /* panel units */
    bool seen_xy;        /* a position arrived since the contact began */
    int32_t focus;       /* index into the foci, -1: none held */
};

struct hd_touch {
    struct hd_touch_map map;
    double max_distance_m, hysteresis_m;
    uint32_t focus_count;
    uint32_t focus_id[HD_TOUCH_MAX_FOCI];
    double focus_xy_m[HD_TOUCH_MAX_FOCI][2];
    bool multitouch;                               /* protocol B device (has ABS_MT_SLOT) */
    uint32_t slot;                                 /* current slot */
    int32_t single_touch_id;                       /* single-touch panels: presses numbered as tracking ids */
    struct hd_touch_contact now[HD_TOUCH_SLOTS];   /* being updated by the frame in progress */
    struct hd_touch_contact frame[HD_TOUCH_SLOTS]; /* as of the last SYN_REPORT */
    uint64_t touches, refires, out_of_range, dropped_frames, ignored_slots;
};

/* Foci from the table (ids and positions); more than HD_TOUCH_MAX_FOCI: -E2BIG. */
int hd_touch_init(struct hd_touch *t, const struct hd_touch_map *map, double max_distance_m, double hysteresis_m,
                  bool multitouch, uint32_t focus_count, const uint32_t *focus_id, const double *focus_xy_m);

/* A reloaded table's foci replace the current ones (-E2BIG: too many, the
 * old ones stay). Contacts stay down but hold no focus: each plays its
 * nearest focus of the new table at its next frame. */
int hd_touch_set_foci(struct hd_touch *t, uint32_t focus_count, const uint32_t *focus_id, const double *focus_xy_m);

/* Nearest focus to (x, y) in metres: its index and distance, or -1 with no foci. */
int32_t hd_touch_nearest(const struct hd_touch *t, double x_m, double y_m, double *distance_m);

/* Feed one input event (type, code, value as in linux/input.h). Returns 1
 * with *out filled (focus ids, t_ns = timestamp_ns) at a SYN_REPORT that
 * starts foci, 0 otherwise. */
int hd_touch_event(struct hd_touch *t, uint16_t type, uint16_t code, int32_t value, uint64_t timestamp_ns,
                   struct hd_event *out);

/* The device went away: every contact ends (a reconnected device starts clean). */
void hd_touch_lost(struct hd_touch *t);

/* Contacts down as of the last frame. */
uint32_t hd_touch_contacts(const struct hd_touch *t);

#endif
