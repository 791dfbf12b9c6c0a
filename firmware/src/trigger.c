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
    if (s->locked && timestamp_ns < s->locked_until_ns && s->locked_until_ns - timestamp_ns <= t->lockout_ns) {
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

static int is_ws(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

static const char *skip_ws(const char *p)
{
    while (is_ws(*p))
        p++;
    return p;
}

/* A word of the line, where it stands: [p, p + n). */
struct span {
    const char *p;
    size_t n;
};

static const char *next_word(const char *p, struct span *w)
{
    p = skip_ws(p);
    w->p = p;
    while (*p && !is_ws(*p))
        p++;
    w->n = (size_t)(p - w->p);
    return p;
}

static int is_word(struct span w, const char *s) { return w.n == strlen(s) && !memcmp(w.p, s, w.n); }

/* The word into buf as a C string; 0 if it does not fit. */
static int copy_word(struct span w, char *buf, size_t cap)
{
    if (w.n >= cap)
        return 0;
    memcpy(buf, w.p, w.n);
    buf[w.n] = '\0';
    return 1;
}

/* What a message quotes of the sender's text: at most 40 bytes, and the
 * whole length when cut. (Escaping is the log's: log.h.) */
static const char *quoted(char buf[80], const char *p, size_t n)
{
    if (n <= 40)
        snprintf(buf, 80, "'%.*s'", (int)n, p);
    else
        snprintf(buf, 80, "'%.40s...' (%zu bytes)", p, n);
    return buf;
}

int hd_host_parse(const char *line, struct hd_event *out, char *err, unsigned err_size)
{
    char q[80];
    struct span w;
    const char *p = skip_ws(line);
    if (*p == '\0' || *p == '#')
        return 0;
    memset(out, 0, sizeof *out);
    out->frame = -1;
    p = next_word(p, &w);
    if (is_word(w, "at")) {
        char num[32];
        struct span f;
        p = next_word(p, &f);
        char *end;
        errno = 0;
        long long v = copy_word(f, num, sizeof num) ? strtoll(num, &end, 10) : -1;
        if (v < 0 || !num[0] || num[0] == '-' || num[0] == '+' || *end || errno) {
            snprintf(err, err_size, "'at' needs a frame index >= 0, got %s", quoted(q, f.p, f.n));
            return -EINVAL;
        }
        out->frame = v;
        p = next_word(p, &w);
    }
    bool single = is_word(w, "focus");
    if (!single && !is_word(w, "foci")) {
        snprintf(err, err_size, "unknown command %s (expected focus N, foci A,B or at FRAME ...)", quoted(q, w.p, w.n));
        return -EINVAL;
    }
    struct span l;
    p = next_word(p, &l);
    const char *rest = skip_ws(p);
    if (*rest != '\0' && *rest != '#') {
        snprintf(err, err_size, "unexpected text after the focus list: %s", quoted(q, rest, strlen(rest)));
        return -EINVAL;
    }
    char list[256];
    int n =
        copy_word(l, list, sizeof list) ? hd_parse_uint_list(list, out->focus_ids, HD_MAX_EVENT_FOCI, UINT32_MAX) : -1;
    if (n < 1 || (single && n != 1)) {
        snprintf(err, err_size, "%s is not %s", quoted(q, l.p, l.n),
                 single ? "one focus id" : "a comma-separated list of up to 16 focus ids");
        return -EINVAL;
    }
    out->focus_count = (uint32_t)n;
    return 1;
}

int hd_host_parse_line(const char *line, size_t len, struct hd_event *out, char *err, unsigned err_size)
{
    const char *nul = memchr(line, '\0', len);
    if (nul) {
        snprintf(err, err_size, "a NUL byte at column %zu: not a text line", (size_t)(nul - line) + 1);
        return -EINVAL;
    }
    return hd_host_parse(line, out, err, err_size);
}
