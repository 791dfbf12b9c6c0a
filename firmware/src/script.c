/* script.c - the script reader (pure: no device, no logging). */
#define _POSIX_C_SOURCE 200809L
#include "script.h"

#include "trigger.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

void hd_script_free(struct hd_script *s)
{
    free(s->events);
    s->events = NULL;
    s->count = 0;
}

static int refuse(struct hd_script *s, int rc, char err[HD_ERR_MAX], const char *name, unsigned no, const char *what)
{
    snprintf(err, HD_ERR_MAX, "%.400s:%u: %.900s", name, no, what);
    hd_script_free(s);
    return rc;
}

int hd_script_read(FILE *f, const char *name, struct hd_script *s, char err[HD_ERR_MAX])
{
    char line[HD_TRIGGER_LINE_MAX + 2];
    unsigned no = 0;
    size_t cap = 0;
    memset(s, 0, sizeof *s);
    for (;;) {
        /* Read by hand, not fgets: the line's true length shows a NUL in it. */
        size_t len = 0;
        int c;
        while ((c = getc(f)) != EOF && c != '\n')
            if (len < HD_TRIGGER_LINE_MAX + 1)
                line[len++] = (char)c;
        if (c == EOF && len == 0)
            break;
        no++;
        char msg[200];
        if (len > HD_TRIGGER_LINE_MAX) {
            snprintf(msg, sizeof msg, "line longer than %u characters", HD_TRIGGER_LINE_MAX);
            return refuse(s, -EINVAL, err, name, no, msg);
        }
        line[len] = '\0';
        struct hd_event ev;
        int r = hd_host_parse_line(line, len, &ev, msg, sizeof msg);
        if (r == 0)
            continue;
        if (r < 0)
            return refuse(s, -EINVAL, err, name, no, msg);
        if (ev.frame < 0)
            return refuse(s, -EINVAL, err, name, no, "every script line needs 'at FRAME'");
        if (s->count && ev.frame < s->events[s->count - 1].frame) {
            snprintf(msg, sizeof msg, "frame %lld is before the previous line's (%lld)", (long long)ev.frame,
                     (long long)s->events[s->count - 1].frame);
            return refuse(s, -EINVAL, err, name, no, msg);
        }
        if (s->count == cap) {
            cap = cap ? 2 * cap : 64;
            struct hd_event *n = realloc(s->events, cap * sizeof *n);
            if (!n)
                return refuse(s, -ENOMEM, err, name, no, "out of memory");
            s->events = n;
        }
        s->events[s->count++] = ev;
    }
    if (ferror(f))
        return refuse(s, -EIO, err, name, no + 1, "read error");
    return 0;
}

int hd_script_load(const char *path, struct hd_script *s, char err[HD_ERR_MAX])
{
    FILE *f = strcmp(path, "-") ? fopen(path, "r") : stdin;
    if (!f) {
        int e = errno;
        snprintf(err, HD_ERR_MAX, "%.400s: cannot open script: %s", path, strerror(e));
        memset(s, 0, sizeof *s);
        return -e;
    }
    int rc = hd_script_read(f, path, s, err);
    if (f != stdin)
        fclose(f);
    return rc;
}
