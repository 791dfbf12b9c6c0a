/* haptic_file.h - the one rule for opening an input file to read whole: a
 * table, a board file, a WAV plan, a sysfs temperature, a control file.
 *
 * The path is opened O_RDONLY | O_CLOEXEC | O_NONBLOCK, so a FIFO at the
 * path cannot block the open; the descriptor is kept only if fstat says it
 * is a regular file (a directory, a FIFO, a device or a socket is refused,
 * and which one is said), and a file larger than a bound is refused before
 * anything is read. The function writes no message: it says what it refused
 * and why, and each caller words its own. */
#ifndef HAPTIC_FILE_H
#define HAPTIC_FILE_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* A max_bytes that bounds nothing (the file is read only in part, or not by size). */
#define HAPTIC_FILE_NO_LIMIT UINT64_MAX

typedef enum haptic_file_refusal {
    HAPTIC_FILE_OPENED = 0,  /* a regular file within the bound: *fd is open */
    HAPTIC_FILE_CANNOT_OPEN, /* open() failed: error is its errno */
    HAPTIC_FILE_NOT_REGULAR, /* fstat() failed (error: its errno) or no regular file (error 0): kind says which */
    HAPTIC_FILE_TOO_BIG,     /* size > max_bytes */
} haptic_file_refusal;

typedef enum haptic_file_kind {
    HAPTIC_FILE_REGULAR = 0,
    HAPTIC_FILE_DIRECTORY,
    HAPTIC_FILE_FIFO,
    HAPTIC_FILE_DEVICE_OR_SOCKET, /* and what a failed fstat() reports */
} haptic_file_kind;

typedef struct haptic_file_status {
    haptic_file_refusal refusal;
    haptic_file_kind kind; /* what fstat() said the path is (HAPTIC_FILE_DEVICE_OR_SOCKET if it failed) */
    int error;             /* errno of the failed open() or fstat(), else 0 */
    uint64_t size;         /* st_size when fstat() succeeded, else 0 */
} haptic_file_status;

/* Opens path as above. Returns 0 with *fd open (the caller reads and closes
 * it), or, with *fd = -1 and the descriptor already closed: -errno if the
 * open failed, -EINVAL if the path is no regular file (or fstat failed),
 * -EFBIG if its size is larger than max_bytes. status says which, always. */
int haptic_file_open_regular(const char *path, uint64_t max_bytes, int *fd, haptic_file_status *status);

/* "directory", "FIFO", "device or socket" ("regular file" for HAPTIC_FILE_REGULAR). */
const char *haptic_file_kind_name(haptic_file_kind kind);

#ifdef __cplusplus
}
#endif

#endif
