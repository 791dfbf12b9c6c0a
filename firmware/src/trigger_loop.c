/* trigger_loop.c - the trigger thread (see trigger_loop.h). */
#define _GNU_SOURCE
#include "trigger_loop.h"

#include "engine.h"
#include "log.h"

#include <errno.h>
#include <poll.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Host trigger lines from a FIFO or stdin: one warning per bad line (a line
 * too long is one warning, however long), at most HOST_WARN_BURST a second,
 * the rest counted (log.h). */
#define HOST_WARN_BURST 10u

struct line_reader {
    char buf[HD_TRIGGER_LINE_MAX + 2];
    size_t len;
    unsigned line_no;
    size_t overflow; /* bytes of a line too long seen so far; 0: none */
    struct hd_log_limit warn;
};

static const char *host_source(const struct hd_trigger_loop *l, char src[HD_PATH_MAX + 16])
{
    snprintf(src, HD_PATH_MAX + 16, "triggers %s", l->host_name);
    return src;
}

static void host_warn(struct hd_trigger_loop *l, struct line_reader *r, unsigned line_no, const char *what)
{
    char src[HD_PATH_MAX + 16];
    host_source(l, src);
    if (hd_log_limit_allow(&r->warn, hd_now_ns(), src))
        hd_log(LOG_WARNING, "%s:%u: %s (ignored)", src, line_no, what);
}

static void host_line(struct hd_trigger_loop *l, struct line_reader *r, const char *line, size_t len)
{
    struct hd_event ev;
    char err[200];
    int rc = hd_host_parse_line(line, len, &ev, err, sizeof err);
    if (rc < 0) {
        host_warn(l, r, r->line_no, err);
        return;
    }
    if (rc == 0)
        return;
    if (ev.frame >= 0) {
        host_warn(l, r, r->line_no, "'at FRAME' needs --script");
        return;
    }
    ev.t_ns = hd_now_ns();
    l->push(l->push_ctx, &ev);
}

static void host_overflow_ends(struct hd_trigger_loop *l, struct line_reader *r, size_t tail)
{
    char what[96];
    snprintf(what, sizeof what, "line of %zu bytes, longer than %u", r->overflow + tail, HD_TRIGGER_LINE_MAX);
    host_warn(l, r, r->line_no, what);
    r->overflow = 0;
}

/* Returns 0 on EOF, 1 if more may come. */
static int host_read(struct hd_trigger_loop *l, struct line_reader *r)
{
    ssize_t n = read(l->host_fd, r->buf + r->len, sizeof r->buf - 1 - r->len);
    if (n < 0)
        return errno == EINTR || errno == EAGAIN ? 1 : 0;
    if (n == 0) {
        if (r->overflow || r->len) { /* a last line without its newline */
            r->line_no++;
            if (r->overflow)
                host_overflow_ends(l, r, r->len);
            else
                host_line(l, r, (r->buf[r->len] = '\0', r->buf), r->len);
        }
        char src[HD_PATH_MAX + 16];
        hd_log_limit_flush(&r->warn, host_source(l, src));
        return 0;
    }
    r->len += (size_t)n;
    char *start = r->buf, *nl;
    while ((nl = memchr(start, '\n', r->len - (size_t)(start - r->buf)))) {
        *nl = '\0';
        r->line_no++;
        if (r->overflow)
            host_overflow_ends(l, r, (size_t)(nl - start));
        else
            host_line(l, r, start, (size_t)(nl - start));
        start = nl + 1;
    }
    r->len -= (size_t)(start - r->buf);
    memmove(r->buf, start, r->len);
    if (r->len == sizeof r->buf - 1) { /* no newline in a full buffer: the line is too long */
        r->overflow += r->len;
        r->len = 0;
    }
    return 1;
}

static void gpio_ready(struct hd_trigger_loop *l, unsigned i, short revents)
{
    struct hd_gpio *g = l->gpio;
    if (revents & (POLLERR | POLLNVAL)) {
        hd_line_health_fd_error(&l->health, i);
        hd_log(LOG_ERR, "GPIO line %u: event fd failed; line disabled", g->offsets[i]);
        return;
    }
    if (!(revents & POLLIN))
        return;
    struct hd_event ev;
    int rc = hd_gpio_read(g, i, l->trigger, &ev);
    switch (hd_line_health_read(&l->health, i, rc)) {
    case HD_LINE_OK:
        if (rc == 1)
            l->push(l->push_ctx, &ev);
        break;
    case HD_LINE_GLITCH:
        hd_log(LOG_WARNING, "GPIO line %u: event read failed: %s", g->offsets[i], strerror(-rc));
        break;
    case HD_LINE_DISABLED:
        hd_log(LOG_ERR, "GPIO line %u: %u read errors in a row (last: %s); line disabled", g->offsets[i],
               HD_LINE_MAX_READ_ERRORS, strerror(-rc));
        break;
    }
}

struct hd_touch_foci *hd_touch_foci_of(const haptic_table *t)
{
    const size_t n = t->focus_count;
    struct hd_touch_foci *f = malloc(sizeof *f + n * sizeof *f->id + 2 * n * sizeof *f->xy_m + sizeof(double));
    if (!f)
        return NULL;
    f->count = (uint32_t)n;
    f->xy_m = (double *)(f + 1);
    f->id = (uint32_t *)(f->xy_m + 2 * n);
    for (uint32_t i = 0; i < n; i++) {
        haptic_focus_info info = {0};
        haptic_table_focus(t, i, &info); /* the table is validated: cannot fail */
        f->id[i] = info.id;
        f->xy_m[2 * i] = info.x_m;
        f->xy_m[2 * i + 1] = info.y_m;
    }
    return f;
}

static void take_new_foci(struct hd_trigger_loop *l)
{
    struct hd_touch_foci *f = atomic_exchange(&l->next_foci, NULL);
    if (!f)
        return;
    if (hd_touch_set_foci(l->touch, f->count, f->id, f->xy_m) != 0)
        hd_log(LOG_ERR, "touch input: the reloaded table has %u foci, more than %u: the previous foci stay", f->count,
               HD_TOUCH_MAX_FOCI);
    free(f);
}

static void touch_gone(struct hd_trigger_loop *l, int err)
{
    hd_log(LOG_ERR,
           "touch device %s ('%s') gone (%s): hapticd keeps running on its other triggers and looks "
           "for it again every second",
           l->evdev->path, l->evdev->name, strerror(-err));
    hd_evdev_close(l->evdev);
    hd_touch_lost(l->touch);
}

static void touch_retry(struct hd_trigger_loop *l, uint64_t *last_try_ns)
{
    uint64_t now = hd_now_ns();
    if (now - *last_try_ns < 1000000000u)
        return;
    *last_try_ns = now;
    if (hd_evdev_reopen(l->evdev, l->touch) == 0)
        hd_log(LOG_INFO, "touch device %s ('%s') is back", l->evdev->path, l->evdev->name);
}

void *hd_trigger_loop_run(void *arg)
{
    struct hd_trigger_loop *l = arg;
    struct line_reader reader = {.warn = {.burst = HOST_WARN_BURST, .window_ns = 1000000000u}};
    struct pollfd pfd[3 + HD_MAX_LINES];
    int host_open = l->host_fd >= 0;
    const unsigned lines = l->gpio ? l->gpio->count : 0;
    uint64_t touch_tried_ns = 0;
    for (;;) {
        nfds_t n = 0;
        const int touch_fd = l->evdev ? l->evdev->fd : -1;
        pfd[n++] = (struct pollfd){.fd = l->stop_fd, .events = POLLIN};
        pfd[n++] = (struct pollfd){.fd = host_open ? l->host_fd : -1, .events = POLLIN};
        pfd[n++] = (struct pollfd){.fd = touch_fd, .events = POLLIN};
        for (unsigned i = 0; i < lines; i++)
            pfd[n++] = (struct pollfd){.fd = l->health.dead[i] ? -1 : l->gpio->fds[i], .events = POLLIN};
        if (poll(pfd, n, l->evdev && touch_fd < 0 ? 1000 : -1) < 0) {
            if (errno == EINTR)
                continue;
            hd_log(LOG_ERR, "trigger poll: %s", strerror(errno));
            return NULL;
        }
        if (pfd[0].revents) {
            char src[HD_PATH_MAX + 16];
            hd_log_limit_flush(&reader.warn, host_source(l, src));
            return NULL;
        }
        if (l->evdev)
            take_new_foci(l);
        if (host_open && (pfd[1].revents & (POLLIN | POLLHUP)) && !host_read(l, &reader)) {
            hd_log(LOG_INFO, "trigger input %s closed", l->host_name);
            host_open = 0;
        }
        if (touch_fd >= 0 && pfd[2].revents) {
            int rc = hd_evdev_read(l->evdev, l->touch, l->push, l->push_ctx);
            if (rc == 0 && (pfd[2].revents & (POLLERR | POLLHUP | POLLNVAL)))
                rc = -ENODEV;
            if (rc < 0)
                touch_gone(l, rc);
        } else if (l->evdev && touch_fd < 0) {
            touch_retry(l, &touch_tried_ns);
        }
        for (unsigned i = 0; i < lines; i++)
            if (!l->health.dead[i])
                gpio_ready(l, i, pfd[3 + i].revents);
    }
}
