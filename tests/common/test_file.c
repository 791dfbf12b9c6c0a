/* The one rule for opening an input file to read whole (haptic_file.h): a
 * regular file within the bound is opened non-blocking and close-on-exec; a
 * FIFO is refused without blocking, a directory and a device are refused and
 * named, a file over the bound is refused with its size, a missing path with
 * its errno; a refused path leaves no descriptor open. */
#define _POSIX_C_SOURCE 200809L
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#include <haptic_file.h>

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define TEST_TMPDIR_PREFIX "hfile"
#include "test_tmpdir.h"

/* The lowest free descriptor: the same before and after a refusal when the
 * refusal closed what it opened. */
static int lowest_free_fd(void)
{
    int fd = dup(0);
    assert_true(fd >= 0);
    close(fd);
    return fd;
}

static void write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    assert_int_equal(fputs(text, f) >= 0, 1);
    assert_int_equal(fclose(f), 0);
}

static void opens_a_regular_file_within_the_bound(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/five", tmpdir);
    write_file(path, "hello");
    int fd = -2;
    haptic_file_status st;
    /* At the bound: a file of exactly max_bytes is kept. */
    assert_int_equal(haptic_file_open_regular(path, 5, &fd, &st), 0);
    assert_true(fd >= 0);
    assert_int_equal(st.refusal, HAPTIC_FILE_OPENED);
    assert_int_equal(st.kind, HAPTIC_FILE_REGULAR);
    assert_int_equal(st.error, 0);
    assert_int_equal(st.size, 5);
    /* Opened read-only, non-blocking, close-on-exec. */
    const int fl = fcntl(fd, F_GETFL);
    assert_int_equal(fl & O_ACCMODE, O_RDONLY);
    assert_true(fl & O_NONBLOCK);
    assert_true(fcntl(fd, F_GETFD) & FD_CLOEXEC);
    char buf[8] = {0};
    assert_int_equal(read(fd, buf, sizeof buf), 5);
    assert_string_equal(buf, "hello");
    assert_int_equal(close(fd), 0);

    /* Without a bound, and an empty file at a bound of 0. */
    assert_int_equal(haptic_file_open_regular(path, HAPTIC_FILE_NO_LIMIT, &fd, &st), 0);
    assert_int_equal(st.size, 5);
    assert_int_equal(close(fd), 0);
    snprintf(path, sizeof path, "%s/empty", tmpdir);
    write_file(path, "");
    assert_int_equal(haptic_file_open_regular(path, 0, &fd, &st), 0);
    assert_int_equal(st.size, 0);
    assert_int_equal(close(fd), 0);
}

static void refuses_a_file_over_the_bound_with_its_size(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/six", tmpdir);
    write_file(path, "hello!");
    const int free_fd = lowest_free_fd();
    int fd = -2;
    haptic_file_status st;
    assert_int_equal(haptic_file_open_regular(path, 5, &fd, &st), -EFBIG);
    assert_int_equal(fd, -1);
    assert_int_equal(st.refusal, HAPTIC_FILE_TOO_BIG);
    assert_int_equal(st.kind, HAPTIC_FILE_REGULAR);
    assert_int_equal(st.error, 0);
    assert_int_equal(st.size, 6);
    assert_int_equal(lowest_free_fd(), free_fd);
}

/* Before the open was non-blocking a FIFO blocked in open() until a writer
 * came; the alarm turns such a hang into a failure instead of a timeout. */
static void refuses_a_fifo_without_blocking(void **state)
{
    (void)state;
    char fifo[300];
    snprintf(fifo, sizeof fifo, "%s/f.fifo", tmpdir);
    assert_int_equal(mkfifo(fifo, 0600), 0);
    const int free_fd = lowest_free_fd();
    int fd = -2;
    haptic_file_status st;
    alarm(10);
    assert_int_equal(haptic_file_open_regular(fifo, HAPTIC_FILE_NO_LIMIT, &fd, &st), -EINVAL);
    alarm(0);
    assert_int_equal(fd, -1);
    assert_int_equal(st.refusal, HAPTIC_FILE_NOT_REGULAR);
    assert_int_equal(st.kind, HAPTIC_FILE_FIFO);
    assert_int_equal(st.error, 0);
    assert_string_equal(haptic_file_kind_name(st.kind), "FIFO");
    assert_int_equal(lowest_free_fd(), free_fd);
    assert_int_equal(unlink(fifo), 0);
}

static void refuses_a_directory_and_a_device_naming_which(void **state)
{
    (void)state;
    const int free_fd = lowest_free_fd();
    int fd = -2;
    haptic_file_status st;
    assert_int_equal(haptic_file_open_regular(tmpdir, HAPTIC_FILE_NO_LIMIT, &fd, &st), -EINVAL);
    assert_int_equal(fd, -1);
    assert_int_equal(st.refusal, HAPTIC_FILE_NOT_REGULAR);
    assert_int_equal(st.kind, HAPTIC_FILE_DIRECTORY);
    assert_int_equal(st.error, 0);
    assert_string_equal(haptic_file_kind_name(st.kind), "directory");
    /* A device that would read forever, refused before any read, whatever the bound. */
    fd = -2;
    assert_int_equal(haptic_file_open_regular("/dev/zero", HAPTIC_FILE_NO_LIMIT, &fd, &st), -EINVAL);
    assert_int_equal(fd, -1);
    assert_int_equal(st.refusal, HAPTIC_FILE_NOT_REGULAR);
    assert_int_equal(st.kind, HAPTIC_FILE_DEVICE_OR_SOCKET);
    assert_string_equal(haptic_file_kind_name(st.kind), "device or socket");
    assert_int_equal(lowest_free_fd(), free_fd);
}

static void refuses_a_missing_path_with_its_errno(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/missing/x", tmpdir);
    int fd = -2;
    haptic_file_status st;
    assert_int_equal(haptic_file_open_regular(path, HAPTIC_FILE_NO_LIMIT, &fd, &st), -ENOENT);
    assert_int_equal(fd, -1);
    assert_int_equal(st.refusal, HAPTIC_FILE_CANNOT_OPEN);
    assert_int_equal(st.error, ENOENT);
    assert_int_equal(st.size, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(opens_a_regular_file_within_the_bound),
        cmocka_unit_test(refuses_a_file_over_the_bound_with_its_size),
        cmocka_unit_test(refuses_a_fifo_without_blocking),
        cmocka_unit_test(refuses_a_directory_and_a_device_naming_which),
        cmocka_unit_test(refuses_a_missing_path_with_its_errno),
    };
    return cmocka_run_group_tests(tests, make_tmpdir, remove_tmpdir);
}
