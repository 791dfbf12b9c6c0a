/* vboard_uinput.c - a multi-touch panel made with uinput: the kernel's input
 * core stamps its events and evdev delivers them, as for a real panel's
 * driver. Protocol B (slots and tracking ids, Documentation/input/
 * multi-touch-protocol.rst) plus the single-touch BTN_TOUCH / ABS_X / ABS_Y
 * a legacy reader uses. */
#define _GNU_SOURCE
#include "vboard.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <linux/uinput.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <time.h>
#include <unistd.h>

static int emit(int fd, unsigned type, unsigned code, int value)
{
    struct input_event ev = {.type = (__u16)type, .code = (__u16)code, .value = value};
    return write(fd, &ev, sizeof ev) == (ssize_t)sizeof ev ? 0 : -errno;
}

static int abs_setup(int fd, unsigned code, int max)
{
    struct uinput_abs_setup a = {.code = (__u16)code, .absinfo = {.minimum = 0, .maximum = max}};
    return ioctl(fd, UI_ABS_SETUP, &a) < 0 ? -errno : 0;
}

/* The evdev node the kernel made for our device (udev-less: scan /dev/input). */
static int find_evdev(struct vb_touch *t)
{
    for (int attempt = 0; attempt < 200; attempt++) {
        DIR *d = opendir("/dev/input");
        struct dirent *de;
        while (d && (de = readdir(d))) {
            if (strncmp(de->d_name, "event", 5))
                continue;
            char path[64], name[64] = "";
            snprintf(path, sizeof path, "/dev/input/%.40s", de->d_name);
            int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
            if (fd < 0)
                continue;
            if (ioctl(fd, EVIOCGNAME(sizeof name - 1), name) >= 0 && !strcmp(name, VB_TOUCH_NAME)) {
                closedir(d);
                int clock = CLOCK_MONOTONIC; /* hapticd's clock, not the default CLOCK_REALTIME */
                if (ioctl(fd, EVIOCSCLOCKID, &clock) < 0) {
                    close(fd);
                    return -errno;
                }
                t->evdev_fd = fd;
                snprintf(t->evdev_path, sizeof t->evdev_path, "%s", path);
                return 0;
            }
            close(fd);
        }
        if (d)
            closedir(d);
        struct timespec ts = {0, 10000000};
        nanosleep(&ts, NULL);
    }
    return -ENODEV;
}

int vb_touch_open(struct vb_touch *t)
{
    t->uinput_fd = t->evdev_fd = -1;
    int fd = open("/dev/uinput", O_WRONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return -errno;
    t->uinput_fd = fd;
    int rc = 0;
    if (ioctl(fd, UI_SET_EVBIT, EV_KEY) < 0 || ioctl(fd, UI_SET_KEYBIT, BTN_TOUCH) < 0 ||
        ioctl(fd, UI_SET_EVBIT, EV_ABS) < 0 || ioctl(fd, UI_SET_PROPBIT, INPUT_PROP_DIRECT) < 0)
        rc = -errno;
    static const unsigned axes[] = {ABS_X, ABS_Y, ABS_MT_POSITION_X, ABS_MT_POSITION_Y};
    for (unsigned i = 0; i < 4 && !rc; i++)
        if (ioctl(fd, UI_SET_ABSBIT, axes[i]) < 0 ||
            (rc = abs_setup(fd, axes[i], i % 2 ? VB_TOUCH_Y_MAX : VB_TOUCH_X_MAX)))
            rc = rc ? rc : -errno;
    if (!rc && (ioctl(fd, UI_SET_ABSBIT, ABS_MT_SLOT) < 0 || ioctl(fd, UI_SET_ABSBIT, ABS_MT_TRACKING_ID) < 0))
        rc = -errno;
    if (!rc && !(rc = abs_setup(fd, ABS_MT_SLOT, 9)))
        rc = abs_setup(fd, ABS_MT_TRACKING_ID, 65535);
    struct uinput_setup setup = {.id = {.bustype = BUS_VIRTUAL, .vendor = 0x1209, .product = 0x0001}};
    snprintf(setup.name, sizeof setup.name, "%s", VB_TOUCH_NAME);
    if (!rc && (ioctl(fd, UI_DEV_SETUP, &setup) < 0 || ioctl(fd, UI_DEV_CREATE) < 0))
        rc = -errno;
    if (!rc)
        rc = find_evdev(t);
    if (rc)
        vb_touch_close(t);
    return rc;
}

void vb_touch_close(struct vb_touch *t)
{
    if (t->evdev_fd >= 0)
        close(t->evdev_fd);
    if (t->uinput_fd >= 0) {
        ioctl(t->uinput_fd, UI_DEV_DESTROY);
        close(t->uinput_fd);
    }
    t->uinput_fd = t->evdev_fd = -1;
}

int vb_touch_down(struct vb_touch *t, unsigned count, const int *x, const int *y)
{
    static int tracking_id;
    int rc = 0;
    for (unsigned k = 0; k < count && !rc; k++) {
        if (!(rc = emit(t->uinput_fd, EV_ABS, ABS_MT_SLOT, (int)k)) &&
            !(rc = emit(t->uinput_fd, EV_ABS, ABS_MT_TRACKING_ID, tracking_id++ & 0xffff)) &&
            !(rc = emit(t->uinput_fd, EV_ABS, ABS_MT_POSITION_X, x[k])))
            rc = emit(t->uinput_fd, EV_ABS, ABS_MT_POSITION_Y, y[k]);
    }
    if (!rc && !(rc = emit(t->uinput_fd, EV_KEY, BTN_TOUCH, 1)) && !(rc = emit(t->uinput_fd, EV_ABS, ABS_X, x[0])) &&
        !(rc = emit(t->uinput_fd, EV_ABS, ABS_Y, y[0])))
        rc = emit(t->uinput_fd, EV_SYN, SYN_REPORT, 0);
    return rc;
}

int vb_touch_up(struct vb_touch *t, unsigned count)
{
    int rc = 0;
    for (unsigned k = 0; k < count && !rc; k++)
        if (!(rc = emit(t->uinput_fd, EV_ABS, ABS_MT_SLOT, (int)k)))
            rc = emit(t->uinput_fd, EV_ABS, ABS_MT_TRACKING_ID, -1);
    if (!rc && !(rc = emit(t->uinput_fd, EV_KEY, BTN_TOUCH, 0)))
        rc = emit(t->uinput_fd, EV_SYN, SYN_REPORT, 0);
    return rc;
}

int vb_touch_read_frame(struct vb_touch *t, int timeout_ms, uint64_t *t_ns, int pos[2][2])
{
    int slot = 0;
    for (;;) {
        struct pollfd p = {.fd = t->evdev_fd, .events = POLLIN};
        int n = poll(&p, 1, timeout_ms);
        if (n <= 0)
            return n < 0 ? -errno : -ETIMEDOUT;
        struct input_event ev;
        if (read(t->evdev_fd, &ev, sizeof ev) != (ssize_t)sizeof ev)
            return -EIO;
        if (ev.type == EV_ABS && ev.code == ABS_MT_SLOT)
            slot = ev.value;
        else if (ev.type == EV_ABS && (ev.code == ABS_MT_POSITION_X || ev.code == ABS_MT_POSITION_Y) && slot < 2)
            pos[slot][ev.code == ABS_MT_POSITION_Y] = ev.value;
        else if (ev.type == EV_SYN && ev.code == SYN_REPORT) {
            *t_ns = (uint64_t)ev.input_event_sec * 1000000000u + (uint64_t)ev.input_event_usec * 1000u;
            return 0;
        }
    }
}
