/* control.c - the user's intensity file (control.h). */
#define _POSIX_C_SOURCE 200809L
#include "control.h"

#include <haptic_file.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int hd_control_parse_db(const char *text, size_t len, double *db, char err[HD_ERR_MAX])
{
    char buf[HD_CONTROL_MAX_BYTES + 1];
    if (len > HD_CONTROL_MAX_BYTES) {
        snprintf(err, HD_ERR_MAX, "%zu bytes: a level is one number of dB", len);
        return -EINVAL;
    }
    memcpy(buf, text, len);
    buf[len] = '\0';
    if (memchr(text, '\0', len)) {
        snprintf(err, HD_ERR_MAX, "a NUL byte: a level is one number of dB");
        return -EINVAL;
    }
    char *end;
    errno = 0;
    const double v = strtod(buf, &end);
    const char *rest = end;
    while (*rest == ' ' || *rest == '\t')
        rest++;
    if (!strncmp(rest, "dB", 2))
        rest += 2;
    while (*rest == ' ' || *rest == '\t' || *rest == '\r' || *rest == '\n')
        rest++;
    if (end == buf || errno || *rest || !isfinite(v)) {
        snprintf(err, HD_ERR_MAX, "'%.*s' is not a number of dB", (int)strcspn(buf, "\r\n"), buf);
        return -EINVAL;
    }
    if (v < HD_CONTROL_MIN_DB || v > HD_CONTROL_MAX_DB) {
        snprintf(err, HD_ERR_MAX, "%g dB is outside %g..%+g dB", v, HD_CONTROL_MIN_DB, HD_CONTROL_MAX_DB);
        return -EINVAL;
    }
    *db = v;
    return 0;
}

int hd_control_poll(struct hd_control *c, double *db, char err[HD_ERR_MAX])
{
    struct stat st;
    if (stat(c->path, &st) != 0) {
        int e = errno;
        snprintf(err, HD_ERR_MAX, "%s: %s", c->path, strerror(e));
        c->seen = 0; /* when it comes back, it is read */
        return -e;
    }
    const int64_t mtime_ns = (int64_t)st.st_mtim.tv_sec * 1000000000 + st.st_mtim.tv_nsec;
    if (c->seen && mtime_ns == c->mtime_ns && st.st_size == c->size && st.st_ino == c->ino)
        return 0;
    c->seen = 1;
    c->mtime_ns = mtime_ns;
    c->size = st.st_size;
    c->ino = st.st_ino;
    /* No bound on the size: at most HD_CONTROL_MAX_BYTES + 1 are read, and
     * more than HD_CONTROL_MAX_BYTES is refused by the parse. */
    int fd;
    haptic_file_status fs;
    const int orc = haptic_file_open_regular(c->path, HAPTIC_FILE_NO_LIMIT, &fd, &fs);
    if (fs.refusal == HAPTIC_FILE_CANNOT_OPEN)
        snprintf(err, HD_ERR_MAX, "%s: %s", c->path, strerror(fs.error));
    else if (orc)
        snprintf(err, HD_ERR_MAX, "%s: not a regular file", c->path);
    if (orc)
        return orc;
    char buf[HD_CONTROL_MAX_BYTES + 1];
    ssize_t n = read(fd, buf, sizeof buf);
    int e = errno;
    close(fd);
    if (n < 0) {
        snprintf(err, HD_ERR_MAX, "%s: %s", c->path, strerror(e));
        return -e;
    }
    if (n == 0)
        return 0;
    int rc = hd_control_parse_db(buf, (size_t)n, db, err);
    if (rc) {
        char msg[HD_ERR_MAX];
        snprintf(msg, sizeof msg, "%s", err);
        snprintf(err, HD_ERR_MAX, "%.400s: %.900s", c->path, msg);
        return rc;
    }
    return 1;
}
