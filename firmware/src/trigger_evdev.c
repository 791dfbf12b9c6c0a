/* trigger_evdev.c - libevdev shim (see trigger_evdev.h). */
#define _GNU_SOURCE
#include "trigger_evdev.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <libevdev/libevdev.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static uint64_t monotonic_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

static int open_node(struct hd_evdev *e, const char *path)
{
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return -errno;
    struct libevdev *dev;
    int rc = libevdev_new_from_fd(fd, &dev);
    if (rc < 0) {
        close(fd);
        return rc;
    }
    /* Event timestamps on our clock, so input latency is measured on it. */
    libevdev_set_clock_id(dev, CLOCK_MONOTONIC);
    e->fd = fd;
    e->dev = dev;
    snprintf(e->path, sizeof e->path, "%s", path);
    snprintf(e->name, sizeof e->name, "%s", libevdev_get_name(dev) ? libevdev_get_name(dev) : "");
    return 0;
}

/* The first /dev/input/event* (in name order) whose name contains `want`. */
static int open_by_name(struct hd_evdev *e, const char *want)
{
    struct dirent **list;
    int n = scandir("/dev/input", &list, NULL, alphasort);
    if (n < 0)
        return -errno;
    int rc = -ENODEV;
    for (int i = 0; i < n; i++) {
        if (rc != 0 && !strncmp(list[i]->d_name, "event", 5)) {
            char path[HD_PATH_MAX];
            snprintf(path, sizeof path, "/dev/input/%.200s", list[i]->d_name);
            if (open_node(e, path) == 0) {
                if (strstr(e->name, want))
                    rc = 0;
                else
                    hd_evdev_close(e);
            }
        }
        free(list[i]);
    }
    free(list);
    return rc;
}

static int find_and_open(struct hd_evdev *e)
{
    if (e->override_path)
        return open_node(e, e->override_path);
    if (e->cfg->device[0])
        return open_node(e, e->cfg->device);
    return open_by_name(e, e->cfg->name);
}

static const char *wanted(const struct hd_evdev *e)
{
    return e->override_path ? e->override_path : e->cfg->device[0] ? e->cfg->device : e->cfg->name;
}

int hd_evdev_open(struct hd_evdev *e, const struct hd_touch_board *cfg, const char *board_path,
                  const char *override_path, struct hd_touch *t, uint32_t focus_count, const uint32_t *focus_id,
                  const double *focus_xy_m, char err[HD_ERR_MAX])
{
    memset(e, 0, sizeof *e);
    e->fd = -1;
    e->cfg = cfg;
    e->override_path = override_path;
    int rc = find_and_open(e);
    if (rc < 0) {
        snprintf(err, HD_ERR_MAX, "cannot open touch device '%s' ([touch] in %s): %s", wanted(e), board_path,
                 rc == -ENODEV && !override_path && !cfg->device[0] ? "no /dev/input/event* has that name"
                                                                    : strerror(-rc));
        return rc;
    }
    const bool mt = libevdev_has_event_code(e->dev, EV_ABS, ABS_MT_SLOT) &&
                    libevdev_has_event_code(e->dev, EV_ABS, ABS_MT_POSITION_X) &&
                    libevdev_has_event_code(e->dev, EV_ABS, ABS_MT_POSITION_Y);
    const unsigned ax = mt ? ABS_MT_POSITION_X : ABS_X, ay = mt ? ABS_MT_POSITION_Y : ABS_Y;
    const struct input_absinfo *ix = libevdev_get_abs_info(e->dev, ax), *iy = libevdev_get_abs_info(e->dev, ay);
    if (!ix || !iy || (!mt && !libevdev_has_event_code(e->dev, EV_KEY, BTN_TOUCH))) {
        snprintf(err, HD_ERR_MAX,
                 "touch device %s ('%s', [touch] in %s) reports neither multi-touch slots "
                 "nor BTN_TOUCH with ABS_X/Y: not a touchscreen",
                 e->path, e->name, board_path);
        hd_evdev_close(e);
        return -ENOTSUP;
    }
    struct hd_touch_map map;
    if (cfg->calib_set == 7) {
        double panel[6], plate[6];
        for (int k = 0; k < 3; k++) {
            panel[2 * k] = cfg->calib[k][0];
            panel[2 * k + 1] = cfg->calib[k][1];
            plate[2 * k] = cfg->calib[k][2];
            plate[2 * k + 1] = cfg->calib[k][3];
        }
        rc = hd_touch_map_from_points(panel, plate, &map); /* checked by the board parser */
    } else {
        rc = hd_touch_map_from_area(ix->minimum, ix->maximum, iy->minimum, iy->maximum, cfg->area_m, &map);
    }
    if (rc == 0)
        rc = hd_touch_init(t, &map, cfg->max_distance_m, cfg->hysteresis_m, mt, focus_count, focus_id, focus_xy_m);
    if (rc != 0) {
        snprintf(err, HD_ERR_MAX, "touch device %s ('%s', [touch] in %s): %s", e->path, e->name, board_path,
                 rc == -E2BIG ? "the table has more foci than touch input serves"
                              : "the panel reports an empty axis range");
        hd_evdev_close(e);
        return rc;
    }
    return hd_evdev_reopen(e, t);
}

int hd_evdev_reopen(struct hd_evdev *e, struct hd_touch *t)
{
    if (!e->dev) {
        int rc = find_and_open(e);
        if (rc < 0)
            return rc;
    }
    /* Where each slot stands now: protocol B sends only values that change,
     * so a contact beginning without a position is at the slot's last one. */
    if (t->multitouch) {
        for (unsigned s = 0; s < HD_TOUCH_SLOTS && (int)s < libevdev_get_num_slots(e->dev); s++) {
            t->now[s].x = t->frame[s].x = libevdev_get_slot_value(e->dev, s, ABS_MT_POSITION_X);
            t->now[s].y = t->frame[s].y = libevdev_get_slot_value(e->dev, s, ABS_MT_POSITION_Y);
            t->now[s].seen_xy = t->frame[s].seen_xy = true;
            /* A finger already down counts as a new touch at its next frame. */
            t->now[s].tracking_id = libevdev_get_slot_value(e->dev, s, ABS_MT_TRACKING_ID);
        }
        int slot = libevdev_get_current_slot(e->dev);
        t->slot = slot >= 0 && (unsigned)slot < HD_TOUCH_SLOTS ? (uint32_t)slot : HD_TOUCH_SLOTS;
    } else {
        t->now[0].x = t->frame[0].x = libevdev_get_event_value(e->dev, EV_ABS, ABS_X);
        t->now[0].y = t->frame[0].y = libevdev_get_event_value(e->dev, EV_ABS, ABS_Y);
        t->now[0].seen_xy = t->frame[0].seen_xy = true;
    }
    return 0;
}

static void feed(struct hd_touch *t, const struct input_event *ev, void (*push)(void *, const struct hd_event *),
                 void *ctx)
{
    uint64_t ts = (uint64_t)ev->input_event_sec * 1000000000u + (uint64_t)ev->input_event_usec * 1000u;
    uint64_t now = monotonic_ns();
    /* Kernel timestamps are CLOCK_MONOTONIC (set above); keep them only when
     * they are plausible, as for GPIO events. */
    if (ts > now || now - ts > 1000000000u)
        ts = now;
    struct hd_event out;
    if (hd_touch_event(t, ev->type, ev->code, ev->value, ts, &out) == 1)
        push(ctx, &out);
}

int hd_evdev_read(struct hd_evdev *e, struct hd_touch *t, void (*push)(void *ctx, const struct hd_event *ev), void *ctx)
{
    if (!e->dev)
        return -ENODEV;
    for (;;) {
        struct input_event ev;
        int rc = libevdev_next_event(e->dev, LIBEVDEV_READ_FLAG_NORMAL, &ev);
        if (rc == -EAGAIN)
            return 0;
        if (rc < 0)
            return rc;
        feed(t, &ev, push, ctx);
        if (rc == LIBEVDEV_READ_STATUS_SYNC) {
            /* ev was SYN_DROPPED: the logic forgot the frame in progress;
             * now the device's state as it is, ending with a SYN_REPORT. */
            while ((rc = libevdev_next_event(e->dev, LIBEVDEV_READ_FLAG_SYNC, &ev)) == LIBEVDEV_READ_STATUS_SYNC)
                feed(t, &ev, push, ctx);
            if (rc < 0 && rc != -EAGAIN)
                return rc;
        }
    }
}

void hd_evdev_close(struct hd_evdev *e)
{
    if (e->dev)
        libevdev_free(e->dev);
    if (e->fd >= 0)
        close(e->fd);
    e->dev = NULL;
    e->fd = -1;
}
