/* haptic_file.c - opening an input file to read whole (haptic_file.h). */
#define _POSIX_C_SOURCE 200809L
#include "haptic_file.h"

#include <errno.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

int haptic_file_open_regular(const char *path, uint64_t max_bytes, int *fd, haptic_file_status *status)
{
    *status = (haptic_file_status){.refusal = HAPTIC_FILE_OPENED, .kind = HAPTIC_FILE_REGULAR};
    *fd = -1;
    /* O_NONBLOCK: a FIFO (or a device) at the path must not block the open;
     * it is refused below as not a regular file. A regular file reads as ever. */
    int f = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (f < 0) {
        status->refusal = HAPTIC_FILE_CANNOT_OPEN;
        status->error = errno;
        return -status->error;
    }
    struct stat st = {0};
    const int stat_error = fstat(f, &st) != 0 ? errno : 0;
    if (stat_error || !S_ISREG(st.st_mode)) {
        close(f);
        status->refusal = HAPTIC_FILE_NOT_REGULAR;
        status->error = stat_error;
        status->kind = stat_error             ? HAPTIC_FILE_DEVICE_OR_SOCKET /* what a zero st_mode said */
                       : S_ISDIR(st.st_mode)  ? HAPTIC_FILE_DIRECTORY
                       : S_ISFIFO(st.st_mode) ? HAPTIC_FILE_FIFO
                                              : HAPTIC_FILE_DEVICE_OR_SOCKET;
        return -EINVAL;
    }
    status->size = (uint64_t)st.st_size;
    /* Bounded before anything is read or allocated. */
    if ((uint64_t)st.st_size > max_bytes) {
        close(f);
        status->refusal = HAPTIC_FILE_TOO_BIG;
        return -EFBIG;
    }
    *fd = f;
    return 0;
}

const char *haptic_file_kind_name(haptic_file_kind kind)
{
    switch (kind) {
    case HAPTIC_FILE_REGULAR:
        return "regular file";
    case HAPTIC_FILE_DIRECTORY:
        return "directory";
    case HAPTIC_FILE_FIFO:
        return "FIFO";
    case HAPTIC_FILE_DEVICE_OR_SOCKET:
        break;
    }
    return "device or socket";
}
