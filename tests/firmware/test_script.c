/* The script reader (--script): events in file order with their frames and
 * foci, comments and blank lines skipped, and every bad line refused with
 * its line number and nothing kept. */
#define _GNU_SOURCE
#include "script.h"

#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <cmocka.h>

static int read_text(const char *text, struct hd_script *s, char err[HD_ERR_MAX])
{
    FILE *f = fmemopen((void *)text, strlen(text), "r");
    assert_non_null(f);
    int rc = hd_script_read(f, "t.txt", s, err);
    fclose(f);
    return rc;
}

static void good_script(void **state)
{
    (void)state;
    struct hd_script s;
    char err[HD_ERR_MAX];
    assert_int_equal(read_text("# a comment\n\nat 0 focus 7\n  at 4800 foci 1,4   # two fingers\n"
                               "at 4800 focus 2\nat 9600 foci 3",
                               &s, err),
                     0);
    assert_int_equal(s.count, 4);
    assert_int_equal(s.events[0].frame, 0);
    assert_int_equal(s.events[0].focus_count, 1);
    assert_int_equal(s.events[0].focus_ids[0], 7);
    assert_int_equal(s.events[1].frame, 4800);
    assert_int_equal(s.events[1].focus_count, 2);
    assert_int_equal(s.events[1].focus_ids[0], 1);
    assert_int_equal(s.events[1].focus_ids[1], 4);
    assert_int_equal(s.events[2].frame, 4800); /* equal frames are allowed */
    assert_int_equal(s.events[3].frame, 9600); /* the last line needs no newline */
    assert_int_equal(s.events[3].focus_ids[0], 3);
    hd_script_free(&s);
    assert_null(s.events);
    /* An empty script is valid: nothing to play. */
    assert_int_equal(read_text("", &s, err), 0);
    assert_int_equal(s.count, 0);
    hd_script_free(&s);
}

static void many_events_grow(void **state)
{
    (void)state;
    /* 1000 lines: past the first allocation of 64 and several doublings. */
    static char text[32 * 1000];
    size_t n = 0;
    for (int i = 0; i < 1000; i++)
        n += (size_t)snprintf(text + n, sizeof text - n, "at %d focus %d\n", 64 * i, i % 9);
    struct hd_script s;
    char err[HD_ERR_MAX];
    assert_int_equal(read_text(text, &s, err), 0);
    assert_int_equal(s.count, 1000);
    assert_int_equal(s.events[999].frame, 64 * 999);
    assert_int_equal(s.events[999].focus_ids[0], 999 % 9);
    hd_script_free(&s);
}

static void refused(const char *text, int want_rc, const char *want_err)
{
    struct hd_script s;
    char err[HD_ERR_MAX] = "";
    int rc = read_text(text, &s, err);
    if (rc != want_rc || strcmp(err, want_err) != 0)
        fail_msg("script '%s': rc %d '%s', expected %d '%s'", text, rc, err, want_rc, want_err);
    assert_null(s.events);
    assert_int_equal(s.count, 0);
}

static void bad_lines_refused_with_their_number(void **state)
{
    (void)state;
    refused("at 0 focus 1\n# ok\nat 10 wiggle 3\n", -EINVAL,
            "t.txt:3: unknown command 'wiggle' (expected focus N, foci A,B or at FRAME ...)");
    refused("focus 1\n", -EINVAL, "t.txt:1: every script line needs 'at FRAME'");
    refused("at 100 focus 1\nat 99 focus 2\n", -EINVAL, "t.txt:2: frame 99 is before the previous line's (100)");
    refused("at -5 focus 1\n", -EINVAL, "t.txt:1: 'at' needs a frame index >= 0, got '-5'");
    refused("\n\nat 0 focus 1,2\n", -EINVAL, "t.txt:3: '1,2' is not one focus id");
    refused("at 0 foci 1,,2\n", -EINVAL, "t.txt:1: '1,,2' is not a comma-separated list of up to 16 focus ids");
    refused("at 0 focus 1 extra\n", -EINVAL, "t.txt:1: unexpected text after the focus list: 'extra'");
}

static void long_line_refused_not_split(void **state)
{
    (void)state;
    /* 600 characters: fgets would hand it over in two pieces, the second of
     * which ("...focus 5" tail) could parse as a line of its own. */
    static char text[700];
    memset(text, ' ', 600);
    memcpy(text + 590, "focus 5", 7);
    memcpy(text, "at 0 ", 5);
    strcpy(text + 600, "\n");
    refused(text, -EINVAL, "t.txt:1: line longer than 510 characters");
    /* 510 characters exactly is fine. */
    memset(text, ' ', 510);
    memcpy(text, "at 0 focus 5", 12);
    strcpy(text + 510, "\n");
    struct hd_script s;
    char err[HD_ERR_MAX];
    assert_int_equal(read_text(text, &s, err), 0);
    assert_int_equal(s.count, 1);
    hd_script_free(&s);
}

/* A NUL inside a line refuses it (fgets and strlen would have stopped at
 * the NUL and kept "at 0 focus 1"). */
static void nul_in_a_line_is_refused(void **state)
{
    (void)state;
    static const char text[] = "at 0 focus 2\nat 0 focus 1\0garbage\n";
    FILE *f = fmemopen((void *)text, sizeof text - 1, "r");
    assert_non_null(f);
    struct hd_script s;
    char err[HD_ERR_MAX];
    assert_int_equal(hd_script_read(f, "t.txt", &s, err), -EINVAL);
    fclose(f);
    assert_string_equal(err, "t.txt:2: a NUL byte at column 13: not a text line");
    assert_null(s.events);
}

static void missing_file_named(void **state)
{
    (void)state;
    struct hd_script s;
    char err[HD_ERR_MAX];
    assert_int_equal(hd_script_load("/nonexistent/script.txt", &s, err), -ENOENT);
    assert_string_equal(err, "/nonexistent/script.txt: cannot open script: No such file or directory");
    assert_null(s.events);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(good_script),
        cmocka_unit_test(many_events_grow),
        cmocka_unit_test(bad_lines_refused_with_their_number),
        cmocka_unit_test(long_line_refused_not_split),
        cmocka_unit_test(nul_in_a_line_is_refused),
        cmocka_unit_test(missing_file_named),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
