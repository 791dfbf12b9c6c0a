/* trigger.c - lockout state machine and host trigger parser (pure logic). */
#define _POSIX_C_SOURCE 200809L
#include "trigger.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void hd_trigger_init(struct hd_trigger *t, const struct hd_board *b)
{
    memset(t, 0, sizeof *t);
    t->lockout_ns = (uint64_t)b->lockout_ms * 1000000u;
    t->line_count = b->line_count;
    for (unsigned i = 0; i < b->line_count; i++) {
        struct hd_trigger_line_state *s = &t->lines[i];
        s->offset = b->lines[i].offset;
        s->active_low = b->lines[i].active_low;
        s->focus_count = b->lines[i].focus_count;
        memcpy(s->focus_ids, b->lines[i].focus_ids, sizeof s->focus_ids);
    }
}

int hd_trigger_line_index(const struct hd_trigger *t, unsigned offset)
{
    for (unsigned i = 0; i < t->line_count; i++)
        if (t->lines[i].offset == offset)
            return (int)i;
    return -1;
}

int hd_trigger_edge(struct hd_trigger *t, unsigned offset, enum hd_edge edge, uint64_t timestamp_ns,
                    struct hd_event *out)
{
    int i = hd_trigger_line_index(t, offset);
    if (i < 0) {
        t->unknown_lines++;
        return -ENOENT;
    }
    struct hd_trigger_line_state *s = &t->lines[i];
    /* Inside the window: start <= ts < start + lockout. A timestamp before the
     * window start (a clock stepped back) opens a new window instead of
     * locking the line until the clock catches up. */
    if (s->locked && timestamp_ns < s->locked_until_ns &&
        s->locked_until_ns - timestamp_ns <= t->lockout_ns) {
        t->bounces++;
        return 0;
    }
    s->locked = t->lockout_ns > 0;
    s->locked_until_ns = timestamp_ns + t->lockout_ns;
    bool press = s->active_low ? edge == HD_EDGE_FALLING : edge == HD_EDGE_RISING;
    if (!press) {
        t->releases++;
        return 0;
    }
    t->fired++;
    out->t_ns = timestamp_ns;
    out->frame = -1;
    out->focus_count = s->focus_count;
    memcpy(out->focus_ids, s->focus_ids, sizeof out->focus_ids);
    return 1;
}

enum hd_line_verdict hd_line_health_read(struct hd_line_health *h, unsigned i, int read_rc)
{
    if (i >= HD_MAX_LINES || h->dead[i])
        return HD_LINE_DISABLED;
    if (read_rc >= 0 || read_rc == -ENOENT) {
        h->read_errors[i] = 0;
        return HD_LINE_OK;
    }
    if (++h->read_errors[i] < HD_LINE_MAX_READ_ERRORS)
        return HD_LINE_GLITCH;
    h->dead[i] = true;
    return HD_LINE_DISABLED;
}

enum hd_line_verdict hd_line_health_fd_error(struct hd_line_health *h, unsigned i)
{
    if (i < HD_MAX_LINES)
        h->dead[i] = true;
    return HD_LINE_DISABLED;
}

static const char *skip_ws(const char *p)
{
    while (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\n')
        p++;
    return p;
}

/* Reads one word into w (at most cap-1 chars); returns the rest. */
static const char *word(const char *p, char *w, size_t cap)
{
    size_t n = 0;
    p = skip_ws(p);
    while (*p && *p != ' ' && *p != '\t' && *p != '\r' && *p != '\n') {
        if (n + 1 < cap)
            w[n++] = *p;
        else
            n = cap; /* too long: mark invalid below */
        p++;
    }
    if (n >= cap) { /* too long: an invalid word the caller reports */
        w[0] = '?';
        n = 1;
    }
    w[n] = '\0';
    return p;
}

int hd_host_parse(const char *line, struct hd_event *out, char *err, unsigned err_size)
{
    char w[64];
    const char *p = skip_ws(line);
    if (*p == '\0' || *p == '#')
        return 0;
    memset(out, 0, sizeof *out);
    out->frame = -1;
    p = word(p, w, sizeof w);
    if (!strcmp(w, "at")) {
        char num[32];
        p = word(p, num, sizeof num);
        char *end;
        errno = 0;
        long long f = strtoll(num, &end, 10);
        if (!num[0] || num[0] == '-' || num[0] == '+' || *end || errno || f < 0) {
            snprintf(err, err_size, "'at' needs a frame index >= 0, got '%s'", num);
            return -EINVAL;
        }
        out->frame = f;
        p = word(p, w, sizeof w);
    }
    bool single = !strcmp(w, "focus");
    if (!single && strcmp(w, "foci")) {
        snprintf(err, err_size, "unknown command '%.40s' (expected focus N, foci A,B or at FRAME ...)", w);
        return -EINVAL;
    }
    char list[256];
    p = word(p, list, sizeof list);
    if (*skip_ws(p) != '\0' && *skip_ws(p) != '#') {
        snprintf(err, err_size, "unexpected text after the focus list: '%.40s'", skip_ws(p));
        return -EINVAL;
    }
    int n = hd_parse_uint_list(list, out->focus_ids, HD_MAX_EVENT_FOCI, UINT32_MAX);
    if (n < 1 || (single && n != 1)) {
        snprintf(err, err_size, "'%.40s' is not %s", list,
                 single ? "one focus id" : "a comma-separated list of up to 16 focus ids");
        return -EINVAL;
    }
    out->focus_count = (uint32_t)n;
    return 1;
}
