/* Host trigger lines (stdin, a FIFO or a script) to hd_host_parse(), the
 * three ways hapticd meets them:
 *   - the whole input as one line (NUL-terminated copy; a NUL inside ends it);
 *   - split at '\n' like the trigger thread's line reader, each line on its own;
 *   - the whole input as a --script file through hd_script_read() (fmemopen:
 *     nothing is written to disk).
 * Invariants: hd_host_parse returns -EINVAL, 0 or 1; on 1 the event has 1..16
 * foci and a frame >= -1; on -EINVAL err is NUL-terminated within its size
 * (and, for a line without '\n', one non-empty line); the answer does not
 * depend on the size of err. A script that reads is in frame order with
 * events the parser could have returned; a refused one is empty with a
 * one-line message. Control bytes in a message are not checked here (the
 * log escapes them).
 * Each line also goes through hd_host_parse_line() (the line as read, its
 * length given: what the trigger thread and the script reader call): a NUL
 * inside is -EINVAL, any other line gets hd_host_parse()'s answer.
 * What reaches the log goes through hd_text_escape() (log.c): the input and
 * each message, escaped into hd_log's buffer and into a small one, must come
 * out without a control byte and unescape to a prefix of what went in (the
 * whole of it when it fits). */
#define _POSIX_C_SOURCE 200809L /* fmemopen */
#include "script.h"
#include "text.h"
#include "trigger.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DAEMON_ERR 200u /* trigger_loop.c and script.c parse into char[200] */

static void check_event(const struct hd_event *ev)
{
    if (ev->focus_count < 1 || ev->focus_count > HD_MAX_EVENT_FOCI || ev->frame < -1)
        abort();
}

static int same_event(const struct hd_event *a, const struct hd_event *b)
{
    return a->frame == b->frame && a->focus_count == b->focus_count &&
           !memcmp(a->focus_ids, b->focus_ids, a->focus_count * sizeof *a->focus_ids);
}

static int hex(char c) /* a digit of a \xNN escape (lower case), or -1 */
{
    return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
}

/* hd_text_escape(src[0..len)) into cap bytes: no control byte (tab and CR
 * included) nor DEL, and it unescapes to exactly the source bytes consumed
 * (so bytes >= 0x80 are copied only as they were). */
static void check_escape_into(const char *src, size_t len, char *dst, size_t cap)
{
    memset(dst, 0xA5, cap);
    size_t used = hd_text_escape(dst, cap, src, len);
    size_t n = strnlen(dst, cap);
    if (used > len || n == cap)
        abort();
    for (size_t i = 0; i < n; i++)
        if ((unsigned char)dst[i] < 0x20 || dst[i] == 0x7F)
            abort();
    size_t back = 0; /* unescape, comparing with the source as we go */
    for (size_t i = 0; i < n; back++) {
        unsigned char c;
        if (dst[i] != '\\') {
            c = (unsigned char)dst[i++];
        } else if (i + 1 < n && dst[i + 1] == '\\') {
            c = '\\';
            i += 2;
        } else {
            if (i + 4 > n || dst[i + 1] != 'x' || hex(dst[i + 2]) < 0 || hex(dst[i + 3]) < 0)
                abort();
            c = (unsigned char)(hex(dst[i + 2]) << 4 | hex(dst[i + 3]));
            i += 4;
        }
        if (back >= used || (unsigned char)src[back] != c)
            abort();
    }
    if (back != used || (len < cap / 4 && used != len)) /* 4 bytes per escape at most */
        abort();
}

static char log_line[1600], log_short[16]; /* hd_log's buffer, and a tight one */

static void check_escape(const char *src, size_t len)
{
    check_escape_into(src, len, log_line, sizeof log_line);
    check_escape_into(src, len, log_short, sizeof log_short);
}

/* Error buffers of exactly the sizes given to the parser: ASan puts a red
 * zone after each global, so a write past one is seen. */
static char err_daemon[DAEMON_ERR], err_13[13], err_1[1];

/* One parse, err pre-filled with non-NUL bytes to see a missing NUL. */
static int parse(const char *line, struct hd_event *ev, char *err, unsigned err_size, int one_line)
{
    memset(err, 0xA5, err_size);
    int rc = hd_host_parse(line, ev, err, err_size);
    if (rc == 1) {
        check_event(ev);
    } else if (rc == -EINVAL) {
        if (!memchr(err, '\0', err_size))
            abort();
        if (one_line && ((err_size > 1 && err[0] == '\0') || strchr(err, '\n')))
            abort();
        if (err_size == DAEMON_ERR) /* the message that is logged */
            check_escape(err, strlen(err));
    } else if (rc != 0) {
        abort();
    }
    return rc;
}

static void check_line(const char *line, size_t len, int one_line)
{
    struct hd_event ev, small;
    int rc = parse(line, &ev, err_daemon, sizeof err_daemon, one_line);
    /* A truncated message changes nothing else. */
    static const struct {
        char *err;
        unsigned size;
    } cut[] = {{err_13, sizeof err_13}, {err_1, sizeof err_1}};
    for (size_t i = 0; i < sizeof cut / sizeof *cut; i++) {
        if (parse(line, &small, cut[i].err, cut[i].size, one_line) != rc || (rc == 1 && !same_event(&small, &ev)))
            abort();
    }
    /* The same bytes with their length: NULs inside count. */
    char *err = err_daemon;
    memset(err, 0xA5, DAEMON_ERR);
    int rc_line = hd_host_parse_line(line, len, &small, err, DAEMON_ERR);
    if (memchr(line, '\0', len)) {
        if (rc_line != -EINVAL || !memchr(err, '\0', DAEMON_ERR) || !err[0] || (one_line && strchr(err, '\n')))
            abort();
    } else if (rc_line != rc || (rc == 1 && !same_event(&small, &ev))) {
        abort();
    }
}

static void check_script(const uint8_t *data, size_t size)
{
    if (size == 0)
        return; /* fmemopen refuses an empty buffer */
    char *copy = malloc(size);
    memcpy(copy, data, size);
    FILE *f = fmemopen(copy, size, "r");
    if (!f)
        abort();
    struct hd_script s;
    char *err = malloc(HD_ERR_MAX);
    memset(err, 0xA5, HD_ERR_MAX);
    int rc = hd_script_read(f, "fuzz.script", &s, err);
    fclose(f);
    if (rc == 0) {
        for (size_t i = 0; i < s.count; i++) {
            check_event(&s.events[i]);
            if (s.events[i].frame < 0 || (i && s.events[i].frame < s.events[i - 1].frame))
                abort();
        }
    } else if (rc == -EINVAL || rc == -ENOMEM) {
        if (s.events || s.count || !memchr(err, '\0', HD_ERR_MAX) || strncmp(err, "fuzz.script:", 12) ||
            strchr(err, '\n'))
            abort();
        check_escape(err, strlen(err));
    } else {
        abort();
    }
    hd_script_free(&s);
    free(err);
    free(copy);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* Exact-size NUL-terminated copy: ASan sees a read past the line's end. */
    char *line = malloc(size + 1);
    memcpy(line, data, size);
    line[size] = '\0';
    check_line(line, size, !memchr(data, '\n', size));
    check_escape(line, size);
    free(line);

    /* Line by line, as the trigger thread hands them over ('\n' replaced by
     * NUL; a last line without '\n' is parsed too, as the script reader does). */
    const uint8_t *start = data, *end = data + size;
    while (start < end) {
        const uint8_t *nl = memchr(start, '\n', (size_t)(end - start));
        size_t len = (size_t)((nl ? nl : end) - start);
        char *one = malloc(len + 1);
        memcpy(one, start, len);
        one[len] = '\0';
        check_line(one, len, 1);
        free(one);
        start = nl ? nl + 1 : end;
    }

    check_script(data, size);
    return 0;
}
