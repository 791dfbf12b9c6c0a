/* libevdev shim with -Wl,--wrap mocks: the map
 * from the panel's axis ranges, events read into the touch logic, the
 * SYN_DROPPED resync read in libevdev's sync mode, a device that goes away,
 * and devices that are not touchscreens or cannot be opened, named. */
#define _POSIX_C_SOURCE 200809L
#include "trigger_evdev.h"

#include <errno.h>
#include <libevdev/libevdev.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <cmocka.h>

static int dev_token;
static int fail_new, has_mt = 1, has_btn = 1, freed;
static struct input_absinfo range_x = {.minimum = 0, .maximum = 7000}, range_y = {.minimum = 0, .maximum = 7000};
static struct {
    int rc; /* what libevdev_next_event returns */
    int want_flags;
    struct input_event ev;
} script[32];
static int nscript, next_ev;

int __wrap_libevdev_new_from_fd(int fd, struct libevdev **dev)
{
    assert_true(fd >= 0);
    if (fail_new)
        return -ENOTTY;
    *dev = (struct libevdev *)&dev_token;
    return 0;
}
int __wrap_libevdev_set_clock_id(struct libevdev *dev, int clockid)
{
    assert_ptr_equal(dev, &dev_token);
    assert_int_equal(clockid, CLOCK_MONOTONIC); /* latency is measured on that clock */
    return 0;
}
const char *__wrap_libevdev_get_name(const struct libevdev *dev)
{
    (void)dev;
    return "Test Panel ft5x06 (38)";
}
int __wrap_libevdev_has_event_code(const struct libevdev *dev, unsigned int type, unsigned int code)
{
    (void)dev;
    if (type == EV_ABS && (code == ABS_MT_SLOT || code == ABS_MT_POSITION_X || code == ABS_MT_POSITION_Y))
        return has_mt;
    if (type == EV_KEY && code == BTN_TOUCH)
        return has_btn;
    return 0;
}
const struct input_absinfo *__wrap_libevdev_get_abs_info(const struct libevdev *dev, unsigned int code)
{
    (void)dev;
    if (code == ABS_MT_POSITION_X || code == ABS_X)
        return &range_x;
    if (code == ABS_MT_POSITION_Y || code == ABS_Y)
        return &range_y;
    return NULL;
}
int __wrap_libevdev_get_num_slots(const struct libevdev *dev)
{
    (void)dev;
    return 10;
}
int __wrap_libevdev_get_slot_value(const struct libevdev *dev, unsigned int slot, unsigned int code)
{
    (void)dev;
    (void)slot;
    return code == ABS_MT_TRACKING_ID ? -1 : 0;
}
int __wrap_libevdev_get_current_slot(const struct libevdev *dev)
{
    (void)dev;
    return 0;
}
int __wrap_libevdev_get_event_value(const struct libevdev *dev, unsigned int type, unsigned int code)
{
    (void)dev;
    (void)type;
    (void)code;
    return 0;
}
int __wrap_libevdev_next_event(struct libevdev *dev, unsigned int flags, struct input_event *ev)
{
    assert_ptr_equal(dev, &dev_token);
    if (next_ev == nscript)
        return -EAGAIN;
    int i = next_ev++;
    if (script[i].want_flags && flags != (unsigned)script[i].want_flags)
        fail_msg("event %d read with flags %u, expected %d", i, flags, script[i].want_flags);
    *ev = script[i].ev;
    return script[i].rc;
}
void __wrap_libevdev_free(struct libevdev *dev)
{
    assert_ptr_equal(dev, &dev_token);
    freed++;
}

static void add(int rc, int flags, uint16_t type, uint16_t code, int32_t value)
{
    script[nscript].rc = rc;
    script[nscript].want_flags = flags;
    script[nscript].ev = (struct input_event){.type = type, .code = code, .value = value};
    nscript++;
}

static void contact(int rc, int flags, int slot, int id, int x, int y)
{
    add(rc, flags, EV_ABS, ABS_MT_SLOT, slot);
    add(rc, flags, EV_ABS, ABS_MT_TRACKING_ID, id);
    add(rc, flags, EV_ABS, ABS_MT_POSITION_X, x);
    add(rc, flags, EV_ABS, ABS_MT_POSITION_Y, y);
}

static const uint32_t ids[2] = {7, 9};
static const double xy[4] = {0.15, 0.15, 0.55, 0.35};
static struct hd_event pushed[8];
static int npushed;

static void collect(void *ctx, const struct hd_event *ev)
{
    assert_ptr_equal(ctx, &npushed);
    pushed[npushed++] = *ev;
}

static int reset(void **state)
{
    (void)state;
    nscript = next_ev = npushed = freed = fail_new = 0;
    has_mt = has_btn = 1;
    return 0;
}

static struct hd_touch_board touch_board(void)
{
    /* /dev/null stands in for the node: it opens; libevdev is the mock. */
    struct hd_touch_board b = {.enabled = true,
                               .device = "/dev/null",
                               .has_area = true,
                               .area_m = {0, 0, 0.7, 0.7},
                               .max_distance_m = 0.05,
                               .hysteresis_m = 0.005};
    return b;
}

static void reads_into_the_touch_logic(void **state)
{
    (void)state;
    static struct hd_touch t;
    static struct hd_evdev e;
    struct hd_touch_board b = touch_board();
    char err[HD_ERR_MAX] = "";
    if (hd_evdev_open(&e, &b, "board.ini", NULL, &t, 2, ids, xy, err) != 0)
        fail_msg("%s", err);
    assert_true(t.multitouch);
    assert_string_equal(e.name, "Test Panel ft5x06 (38)");
    double x, y; /* the area map: 0..7000 -> 0..0.7 m */
    hd_touch_map_apply(&t.map, 3500, 700, &x, &y);
    assert_true(fabs(x - 0.35) < 1e-12 && fabs(y - 0.07) < 1e-12);
    /* Two contacts in one frame: one trigger with both foci. */
    contact(LIBEVDEV_READ_STATUS_SUCCESS, LIBEVDEV_READ_FLAG_NORMAL, 0, 1, 1500, 1500);
    contact(LIBEVDEV_READ_STATUS_SUCCESS, LIBEVDEV_READ_FLAG_NORMAL, 1, 2, 5500, 3500);
    add(LIBEVDEV_READ_STATUS_SUCCESS, LIBEVDEV_READ_FLAG_NORMAL, EV_SYN, SYN_REPORT, 0);
    assert_int_equal(hd_evdev_read(&e, &t, collect, &npushed), 0);
    assert_int_equal(next_ev, nscript); /* read until -EAGAIN */
    assert_int_equal(npushed, 1);
    assert_int_equal(pushed[0].focus_count, 2);
    assert_int_equal(pushed[0].focus_ids[0], 7);
    assert_int_equal(pushed[0].focus_ids[1], 9);
    /* SYN_DROPPED: the state comes back through libevdev's sync mode. Slot 1
     * lifted and came down again (new id) during the drop: it plays again,
     * slot 0 does not. */
    add(LIBEVDEV_READ_STATUS_SYNC, LIBEVDEV_READ_FLAG_NORMAL, EV_SYN, SYN_DROPPED, 0);
    add(LIBEVDEV_READ_STATUS_SYNC, LIBEVDEV_READ_FLAG_SYNC, EV_ABS, ABS_MT_SLOT, 1);
    add(LIBEVDEV_READ_STATUS_SYNC, LIBEVDEV_READ_FLAG_SYNC, EV_ABS, ABS_MT_TRACKING_ID, 3);
    add(LIBEVDEV_READ_STATUS_SYNC, LIBEVDEV_READ_FLAG_SYNC, EV_SYN, SYN_REPORT, 0);
    add(-EAGAIN, LIBEVDEV_READ_FLAG_SYNC, 0, 0, 0);                                      /* end of the sync */
    add(LIBEVDEV_READ_STATUS_SUCCESS, LIBEVDEV_READ_FLAG_NORMAL, EV_SYN, SYN_REPORT, 0); /* normal again */
    assert_int_equal(hd_evdev_read(&e, &t, collect, &npushed), 0);
    assert_int_equal(next_ev, nscript);
    assert_int_equal(t.dropped_frames, 1);
    assert_int_equal(npushed, 2);
    assert_int_equal(pushed[1].focus_count, 1);
    assert_int_equal(pushed[1].focus_ids[0], 9);
    /* The device goes away: the error comes back, nothing is pushed. */
    add(-ENODEV, 0, 0, 0, 0);
    assert_int_equal(hd_evdev_read(&e, &t, collect, &npushed), -ENODEV);
    hd_evdev_close(&e);
    assert_int_equal(freed, 1);
    assert_int_equal(e.fd, -1);
    assert_int_equal(hd_evdev_read(&e, &t, collect, &npushed), -ENODEV); /* closed: no crash */
    /* It comes back: reopened with the same map, a touch plays. */
    hd_touch_lost(&t);
    assert_int_equal(hd_evdev_reopen(&e, &t), 0);
    contact(LIBEVDEV_READ_STATUS_SUCCESS, LIBEVDEV_READ_FLAG_NORMAL, 0, 4, 1500, 1500);
    add(LIBEVDEV_READ_STATUS_SUCCESS, LIBEVDEV_READ_FLAG_NORMAL, EV_SYN, SYN_REPORT, 0);
    assert_int_equal(hd_evdev_read(&e, &t, collect, &npushed), 0);
    assert_int_equal(npushed, 3);
    assert_int_equal(pushed[2].focus_ids[0], 7);
    hd_evdev_close(&e);
}

static void refusals_are_named(void **state)
{
    (void)state;
    static struct hd_touch t;
    static struct hd_evdev e;
    struct hd_touch_board b = touch_board();
    char err[HD_ERR_MAX] = "";
    /* Neither MT slots nor BTN_TOUCH: not a touchscreen (a keyboard, say). */
    has_mt = has_btn = 0;
    assert_int_equal(hd_evdev_open(&e, &b, "board.ini", NULL, &t, 2, ids, xy, err), -ENOTSUP);
    assert_non_null(strstr(err, "/dev/null"));
    assert_non_null(strstr(err, "board.ini"));
    assert_non_null(strstr(err, "not a touchscreen"));
    assert_int_equal(freed, 1);
    /* A node that is not an evdev device. */
    has_mt = has_btn = 1;
    fail_new = 1;
    assert_int_equal(hd_evdev_open(&e, &b, "board.ini", NULL, &t, 2, ids, xy, err), -ENOTTY);
    assert_non_null(strstr(err, "cannot open touch device '/dev/null' ([touch] in board.ini)"));
    /* A path that does not exist; --touch-device overrides the board's. */
    fail_new = 0;
    assert_int_equal(hd_evdev_open(&e, &b, "board.ini", "/nonexistent/event9", &t, 2, ids, xy, err), -ENOENT);
    assert_non_null(strstr(err, "'/nonexistent/event9'"));
    /* An empty axis range cannot be mapped. */
    range_x.maximum = 0;
    assert_int_equal(hd_evdev_open(&e, &b, "board.ini", NULL, &t, 2, ids, xy, err), -EINVAL);
    assert_non_null(strstr(err, "empty axis range"));
    range_x.maximum = 7000;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(reads_into_the_touch_logic, reset),
        cmocka_unit_test_setup(refusals_are_named, reset),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
