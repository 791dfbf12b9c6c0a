/* trigger_gpiod.c - libgpiod 1.6 (v1 API) shim. */
#define _POSIX_C_SOURCE 200809L
#include "trigger_gpiod.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

static int bias_flags(enum hd_bias b)
{
    switch (b) {
    case HD_BIAS_DISABLE:
        return GPIOD_LINE_REQUEST_FLAG_BIAS_DISABLE;
    case HD_BIAS_PULL_UP:
        return GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_UP;
    case HD_BIAS_PULL_DOWN:
        return GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_DOWN;
    case HD_BIAS_AS_IS:
        break;
    }
    return 0;
}

int hd_gpio_open(struct hd_gpio *g, const struct hd_board *b, char err[HD_ERR_MAX])
{
    memset(g, 0, sizeof *g);
    g->chip = gpiod_chip_open_lookup(b->gpio_chip);
    if (!g->chip) {
        int e = errno ? errno : ENODEV;
        snprintf(err, HD_ERR_MAX, "cannot open GPIO chip '%s' ([gpio] chip in %s): %s", b->gpio_chip, b->path,
                 strerror(e));
        return -e;
    }
    for (unsigned i = 0; i < b->line_count; i++) {
        const struct hd_line *l = &b->lines[i];
        struct gpiod_line *line = gpiod_chip_get_line(g->chip, l->offset);
        struct gpiod_line_request_config cfg = {
            .consumer = "hapticd",
            .request_type = GPIOD_LINE_REQUEST_EVENT_BOTH_EDGES,
            .flags = bias_flags(l->bias),
        };
        if (!line || gpiod_line_request(line, &cfg, 0) != 0) {
            int e = errno ? errno : EINVAL;
            snprintf(err, HD_ERR_MAX, "cannot request GPIO line %u on '%s' for edge events ([line %u] in %s): %s",
                     l->offset, b->gpio_chip, l->offset, b->path, strerror(e));
            hd_gpio_close(g);
            return -e;
        }
        g->lines[g->count] = line;
        g->offsets[g->count] = l->offset;
        g->fds[g->count] = gpiod_line_event_get_fd(line);
        g->count++;
    }
    return 0;
}

int hd_gpio_read(struct hd_gpio *g, unsigned i, struct hd_trigger *t, struct hd_event *out)
{
    struct gpiod_line_event ev;
    if (i >= g->count)
        return -EINVAL;
    errno = 0;
    if (gpiod_line_event_read(g->lines[i], &ev) != 0) {
        g->read_errors++;
        return -(errno ? errno : EIO);
    }
    enum hd_edge edge = ev.event_type == GPIOD_LINE_EVENT_RISING_EDGE ? HD_EDGE_RISING : HD_EDGE_FALLING;
    uint64_t ts = (uint64_t)ev.ts.tv_sec * 1000000000u + (uint64_t)ev.ts.tv_nsec;
    int rc = hd_trigger_edge(t, g->offsets[i], edge, ts, out);
    if (rc == 1) {
        /* Latency is measured on CLOCK_MONOTONIC; v1 event timestamps are
         * monotonic on Linux >= 5.7 and realtime before: keep the kernel's
         * only when it is on our clock. */
        struct timespec now;
        clock_gettime(CLOCK_MONOTONIC, &now);
        uint64_t now_ns = (uint64_t)now.tv_sec * 1000000000u + (uint64_t)now.tv_nsec;
        out->t_ns = ts <= now_ns && now_ns - ts < 1000000000u ? ts : now_ns;
    }
    return rc;
}

void hd_gpio_close(struct hd_gpio *g)
{
    for (unsigned i = 0; i < g->count; i++)
        gpiod_line_release(g->lines[i]);
    if (g->chip)
        gpiod_chip_close(g->chip);
    memset(g, 0, sizeof *g);
}
