/* control.h - the user's intensity: a level in dB that whoever may write
 * the board's [control] intensity_file sets at run time (a person's
 * preference: vibrotactile sensitivity differs much between people).
 *
 * The file holds one number of dB ("-6", "+3.5", "-6 dB"), HD_CONTROL_MIN_DB
 * to HD_CONTROL_MAX_DB; 0 is the table's own level. hapticd looks at it on
 * its main thread's beat (every 0.2 s) and reads it when it changed (mtime,
 * size or inode): opened without blocking, refused unless a regular file,
 * at most HD_CONTROL_MAX_BYTES. A bad value is refused in one line and the
 * previous level kept; the level survives table reloads. The mixing law
 * (common/haptic_mix.h) applies it: level x the energy gain, never above
 * the peak limit or [mixer] gain_limit, and the exciters' ratings still
 * bind (protect.h). Why a file: the packaged install creates it under /run
 * with owner hapticd, group hapticd, mode 0660 (systemd-tmpfiles), so root
 * and the group's members may set the level and nobody else, with plain
 * shell tools, and the daemon needs no socket (its unit has no network and
 * a read-only file system). */
#ifndef HD_CONTROL_H
#define HD_CONTROL_H

#include "hd_defs.h"

#include <stdint.h>
#include <sys/types.h>

#define HD_CONTROL_MIN_DB (-40.0)
#define HD_CONTROL_MAX_DB 20.0
#define HD_CONTROL_MAX_BYTES 64u

struct hd_control {
    char path[HD_PATH_MAX];
    int seen; /* a state below was taken */
    int64_t mtime_ns;
    off_t size;
    ino_t ino;
};

/* "-6", "+3.5", "-6 dB", with blanks and a newline around: 0 and *db, or
 * -EINVAL with a one-line reason (not a number, out of range, more text). */
int hd_control_parse_db(const char *text, size_t len, double *db, char err[HD_ERR_MAX]);

/* 1 and *db when the file changed and holds a good level; 0 when it did not
 * change (or is empty: a writer between truncating and writing); a negative
 * errno and err when it cannot be read or holds a bad value (the caller
 * keeps its level). */
int hd_control_poll(struct hd_control *c, double *db, char err[HD_ERR_MAX]);

#endif
