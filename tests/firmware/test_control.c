/* The user's intensity file (control.h): what counts as a level in dB and
 * what is refused in one line; a file read only when it changed, an empty
 * one (a writer between truncate and write) ignored, a bad one refused with
 * the previous level kept by the caller, a FIFO and a directory refused
 * without blocking, a missing file reported and read again when it comes
 * back. */
#define _GNU_SOURCE
#include "control.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

static void levels_and_refusals(void **state)
{
    (void)state;
    char err[HD_ERR_MAX];
    double db = 99;
    static const struct {
        const char *text;
        double db;
    } good[] = {{"-6", -6}, {"+3.5\n", 3.5}, {" -6 dB\n", -6}, {"0", 0}, {"-40", -40}, {"20\r\n", 20}, {"-6dB", -6}};
    for (size_t i = 0; i < sizeof good / sizeof good[0]; i++) {
        assert_int_equal(hd_control_parse_db(good[i].text, strlen(good[i].text), &db, err), 0);
        assert_true(db == good[i].db);
    }
    static const struct {
        const char *text, *why;
    } bad[] = {{"loud", "is not a number of dB"},  {"-6 dBx", "is not a number of dB"},
               {"-40.5", "outside -40..+20 dB"},   {"21", "outside -40..+20 dB"},
               {"nan", "is not a number of dB"},   {"inf", "is not a number of dB"},
               {"-6 -3", "is not a number of dB"}, {"", "is not a number of dB"}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        err[0] = '\0';
        db = 99;
        assert_int_equal(hd_control_parse_db(bad[i].text, strlen(bad[i].text), &db, err), -EINVAL);
        if (!strstr(err, bad[i].why) || strchr(err, '\n'))
            fail_msg("'%s': '%s'", bad[i].text, err);
        assert_true(db == 99);
    }
    assert_int_equal(hd_control_parse_db("-6\0x", 4, &db, err), -EINVAL);
    char big[200];
    memset(big, '1', sizeof big);
    assert_int_equal(hd_control_parse_db(big, sizeof big, &db, err), -EINVAL);
}

static void write_file(const char *path, const char *text)
{
    /* A new inode each time (as an editor's rename would make) so the change
     * is seen even within one mtime tick. */
    char tmp[300];
    snprintf(tmp, sizeof tmp, "%s.new", path);
    FILE *f = fopen(tmp, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    assert_int_equal(rename(tmp, path), 0);
}

static void the_file_is_read_when_it_changes(void **state)
{
    (void)state;
    char dir[] = "/tmp/hd-control-XXXXXX";
    assert_non_null(mkdtemp(dir));
    struct hd_control c = {0};
    snprintf(c.path, sizeof c.path, "%s/intensity_db", dir);
    char err[HD_ERR_MAX];
    double db = 0;
    assert_int_equal(hd_control_poll(&c, &db, err), -ENOENT); /* missing: said, the caller keeps its level */
    assert_non_null(strstr(err, "intensity_db"));
    write_file(c.path, "-6\n");
    assert_int_equal(hd_control_poll(&c, &db, err), 1);
    assert_true(db == -6);
    assert_int_equal(hd_control_poll(&c, &db, err), 0); /* unchanged: not read again */
    write_file(c.path, "");
    assert_int_equal(hd_control_poll(&c, &db, err), 0); /* empty: a writer in the middle */
    write_file(c.path, "+3\n");
    assert_int_equal(hd_control_poll(&c, &db, err), 1);
    assert_true(db == 3);
    write_file(c.path, "\033[2J\n");
    db = 3;
    assert_int_equal(hd_control_poll(&c, &db, err), -EINVAL);
    assert_true(db == 3);
    assert_int_equal(strncmp(err, c.path, strlen(c.path)), 0);
    assert_int_equal(unlink(c.path), 0);
    assert_int_equal(hd_control_poll(&c, &db, err), -ENOENT);
    write_file(c.path, "-12");
    assert_int_equal(hd_control_poll(&c, &db, err), 1); /* back: read again */
    assert_true(db == -12);
    /* A FIFO there: refused, never blocked on. */
    assert_int_equal(unlink(c.path), 0);
    assert_int_equal(mkfifo(c.path, 0600), 0);
    alarm(10);
    assert_int_equal(hd_control_poll(&c, &db, err), -EINVAL);
    assert_non_null(strstr(err, "not a regular file"));
    alarm(0);
    assert_int_equal(unlink(c.path), 0);
    assert_int_equal(rmdir(dir), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(levels_and_refusals),
        cmocka_unit_test(the_file_is_read_when_it_changes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
