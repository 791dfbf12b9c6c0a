/* Trigger state machine (lockout on event timestamps, bouncing edges,
 * simultaneous lines, unknown lines) and the host trigger parser. */
#include "log.h"
#include "text.h"
#include "trigger.h"

#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <cmocka.h>

#define MS 1000000ull

static void two_line_board(struct hd_trigger *t, unsigned lockout_ms)
{
    struct hd_board b;
    hd_board_defaults(&b);
    b.lockout_ms = lockout_ms;
    b.line_count = 2;
    b.lines[0] = (struct hd_line){.offset = 17, .active_low = true, .focus_count = 1, .focus_ids = {3}};
    b.lines[1] = (struct hd_line){.offset = 27, .active_low = false, .focus_count = 2, .focus_ids = {1, 4}};
    hd_trigger_init(t, &b);
}

static void lockout_and_bounce(void **state)
{
    (void)state;
    struct hd_trigger t;
    struct hd_event ev;
    two_line_board(&t, 50);
    const uint64_t t0 = 1000 * MS;
    /* Press (falling on an active-low line) fires at once. */
    assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_FALLING, t0, &ev), 1);
    assert_int_equal(ev.focus_count, 1);
    assert_int_equal(ev.focus_ids[0], 3);
    assert_true(ev.t_ns == t0);
    assert_true(ev.frame == -1);
    /* Contact bounce inside the 50 ms window: ignored. */
    assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_RISING, t0 + 1 * MS, &ev), 0);
    assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_FALLING, t0 + 2 * MS, &ev), 0);
    assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_FALLING, t0 + 50 * MS - 1, &ev), 0);
    assert_int_equal(t.bounces, 3);
    /* Release after the window: no fire, but it opens a window... */
    assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_RISING, t0 + 60 * MS, &ev), 0);
    assert_int_equal(t.releases, 1);
    /* ...so the bounce of the release cannot fire. */
    assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_FALLING, t0 + 70 * MS, &ev), 0);
    /* The window lasts exactly lockout from the edge that opened it (not extended by bounces). */
    assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_FALLING, t0 + 110 * MS, &ev), 1);
    assert_int_equal(t.fired, 2);
}

static void active_high_and_edges(void **state)
{
    (void)state;
    struct hd_trigger t;
    struct hd_event ev;
    two_line_board(&t, 50);
    /* Line 27 is active-high: falling is a release, rising a press. */
    assert_int_equal(hd_trigger_edge(&t, 27, HD_EDGE_FALLING, 0, &ev), 0);
    assert_int_equal(hd_trigger_edge(&t, 27, HD_EDGE_RISING, 100 * MS, &ev), 1);
    assert_int_equal(ev.focus_count, 2);
    assert_int_equal(ev.focus_ids[0], 1);
    assert_int_equal(ev.focus_ids[1], 4);
}

static void simultaneous_lines(void **state)
{
    (void)state;
    struct hd_trigger t;
    struct hd_event a, b;
    two_line_board(&t, 50);
    /* Two fingers at the same instant: each line has its own lockout. */
    assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_FALLING, 5 * MS, &a), 1);
    assert_int_equal(hd_trigger_edge(&t, 27, HD_EDGE_RISING, 5 * MS, &b), 1);
    assert_int_equal(a.focus_ids[0], 3);
    assert_int_equal(b.focus_ids[1], 4);
    /* One line locked does not lock the other. */
    assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_FALLING, 6 * MS, &a), 0);
    assert_int_equal(hd_trigger_edge(&t, 27, HD_EDGE_FALLING, 56 * MS, &b), 0); /* release after window */
    assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_FALLING, 56 * MS, &a), 1);
}

static void unknown_line(void **state)
{
    (void)state;
    struct hd_trigger t;
    struct hd_event ev;
    two_line_board(&t, 50);
    assert_int_equal(hd_trigger_edge(&t, 5, HD_EDGE_FALLING, 0, &ev), -ENOENT);
    assert_int_equal(t.unknown_lines, 1);
    assert_int_equal(t.fired, 0);
    assert_int_equal(hd_trigger_line_index(&t, 27), 1);
    assert_int_equal(hd_trigger_line_index(&t, 28), -1);
}

static void no_lockout_and_clock_step(void **state)
{
    (void)state;
    struct hd_trigger t;
    struct hd_event ev;
    two_line_board(&t, 0);
    for (int i = 0; i < 5; i++)
        assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_FALLING, 10 * MS, &ev), 1);
    two_line_board(&t, 50);
    assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_FALLING, 1000 * MS, &ev), 1);
    /* The clock stepped back by a second: a new window, not a lock until it catches up. */
    assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_FALLING, 0, &ev), 1);
    assert_int_equal(hd_trigger_edge(&t, 17, HD_EDGE_FALLING, 10 * MS, &ev), 0);
}

static void host_commands(void **state)
{
    (void)state;
    struct hd_event ev;
    char err[200];
    assert_int_equal(hd_host_parse("focus 3", &ev, err, sizeof err), 1);
    assert_int_equal(ev.focus_count, 1);
    assert_int_equal(ev.focus_ids[0], 3);
    assert_true(ev.frame == -1);
    assert_int_equal(hd_host_parse("  foci 1,4\r\n", &ev, err, sizeof err), 1);
    assert_int_equal(ev.focus_count, 2);
    assert_int_equal(ev.focus_ids[1], 4);
    assert_int_equal(hd_host_parse("at 4800 focus 3", &ev, err, sizeof err), 1);
    assert_true(ev.frame == 4800);
    assert_int_equal(ev.focus_ids[0], 3);
    assert_int_equal(hd_host_parse("at 0 foci 7, 8 # two", &ev, err, sizeof err), -EINVAL); /* no spaces in list */
    assert_int_equal(hd_host_parse("at 0 foci 7,8 # two", &ev, err, sizeof err), 1);
    assert_int_equal(ev.focus_count, 2);
    assert_int_equal(hd_host_parse("foci 4294967295", &ev, err, sizeof err), 1);
    assert_int_equal(ev.focus_ids[0], 4294967295u);
    assert_int_equal(hd_host_parse("", &ev, err, sizeof err), 0);
    assert_int_equal(hd_host_parse("   # comment", &ev, err, sizeof err), 0);
    static const char *const bad[] = {
        "focus",           "focus 1,2",
        "focus x",         "focus -1",
        "foci 4294967296", "play 3",
        "at focus 3",      "at -5 focus 3",
        "at 12x focus 3",  "at 5",
        "focus 3 4",       "foci 1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17",
        "foci ,1",         "focus 99999999999999999999999999999999999999999999999999999999999999999999999999999"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        err[0] = '\0';
        if (hd_host_parse(bad[i], &ev, err, sizeof err) != -EINVAL || !err[0] || strchr(err, '\n'))
            fail_msg("'%s' accepted or no message ('%s')", bad[i], err);
    }
}

/* A NUL inside a line makes it invalid (a C string would stop there and
 * play "focus 1"); what a message quotes of the sender's text is at most 40
 * bytes and says how long the text was. */
static void host_lines_with_nul_and_long_words(void **state)
{
    (void)state;
    struct hd_event ev;
    char err[200];
    static const char nul_line[] = "focus 1\0garbage";
    assert_int_equal(hd_host_parse_line(nul_line, sizeof nul_line - 1, &ev, err, sizeof err), -EINVAL);
    assert_string_equal(err, "a NUL byte at column 8: not a text line");
    assert_int_equal(hd_host_parse_line("focus 1", 7, &ev, err, sizeof err), 1);
    assert_int_equal(ev.focus_ids[0], 1);
    char line[300];
    memset(line, 'w', 100);
    line[100] = '\0';
    assert_int_equal(hd_host_parse_line(line, 100, &ev, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "unknown command 'wwwwwwwwwwwwwwwwwwwwwwwwwwwwwwwwwwwwwwww...' (100 bytes)"));
    memcpy(line, "foci ", 5);
    memset(line + 5, '1', 200); /* 200 digits: far above any focus id */
    line[205] = '\0';
    assert_int_equal(hd_host_parse(line, &ev, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "...' (200 bytes) is not a comma-separated list"));
    assert_int_equal(hd_host_parse("focus 3 \x1b]0;PWNED\x07", &ev, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "unexpected text after the focus list: '\x1b]0;PWNED\x07'"));
}

/* The log's one escaping rule: printable ASCII and valid UTF-8 stay, control
 * bytes, DEL, invalid UTF-8 (a lone continuation byte, an overlong form, a
 * surrogate, a cut sequence) become \xNN, a backslash \\; a full buffer cuts
 * at a whole escape and says how much it consumed. */
static void log_escapes_what_is_not_text(void **state)
{
    (void)state;
    char out[128];
    static const char in[] = "ok \x1b]0;PWNED\x07 \xc3\xa9 \x80 \xc0\xaf \xed\xa0\x80 \\ \x7f\t\xe2\x82";
    size_t used = hd_text_escape(out, sizeof out, in, sizeof in - 1);
    assert_int_equal(used, sizeof in - 1);
    assert_string_equal(out,
                        "ok \\x1b]0;PWNED\\x07 \xc3\xa9 \\x80 \\xc0\\xaf \\xed\\xa0\\x80 \\\\ \\x7f\\x09\\xe2\\x82");
    /* "\x1b" does not fit in 4 bytes + NUL after "ab": cut before it. */
    char small[6];
    assert_int_equal(hd_text_escape(small, sizeof small,
                                    "ab\x1b"
                                    "c",
                                    4),
                     2);
    assert_string_equal(small, "ab");
    assert_int_equal(hd_text_escape(small, sizeof small, "\xf0\x9f\x98\x80z", 5), 5); /* U+1F600 kept whole */
    assert_string_equal(small, "\xf0\x9f\x98\x80z");
    /* The C1 controls are valid UTF-8 but control characters (CSI, NEL):
     * escaped; U+00A0 just above them is text. */
    assert_int_equal(hd_text_escape(out, sizeof out,
                                    "a\xc2\x9b"
                                    "31m\xc2\x85\xc2\xa0",
                                    10),
                     10);
    assert_string_equal(out, "a\\xc2\\x9b31m\\xc2\\x85\xc2\xa0");
}

/* The flood guard: `burst` messages a window, the rest counted; a new window
 * lets `burst` through again (the summary line is hd_log's, not checked here). */
static void log_limit_lets_a_burst_through(void **state)
{
    (void)state;
    struct hd_log_limit l = {.burst = 3, .window_ns = 1000};
    unsigned allowed = 0;
    for (uint64_t t = 5000; t < 5100; t++)
        allowed += (unsigned)hd_log_limit_allow(&l, t, "test");
    assert_int_equal(allowed, 3);
    assert_int_equal(l.suppressed, 97);
    assert_int_equal(hd_log_limit_allow(&l, 6000, "test"), 1); /* next window: flushed, open again */
    assert_int_equal(l.suppressed, 0);
    assert_int_equal(hd_log_limit_allow(&l, 6999, "test"), 1);
    assert_int_equal(hd_log_limit_allow(&l, 6999, "test"), 1);
    assert_int_equal(hd_log_limit_allow(&l, 6999, "test"), 0);
    assert_int_equal(hd_log_limit_allow(&l, 10, "test"), 1); /* clock stepped back: a new window */
}

/* The policy for a failing GPIO line: 99 failed reads in a row are glitches,
 * the 100th disables the line; a good read (or an edge of an unknown line:
 * the read worked) resets the count; an fd error disables at once; lines are
 * independent. */
static void line_error_policy(void **state)
{
    (void)state;
    static struct hd_line_health h;
    memset(&h, 0, sizeof h);
    for (unsigned k = 1; k < 100; k++)
        assert_int_equal(hd_line_health_read(&h, 0, -EIO), HD_LINE_GLITCH);
    assert_int_equal(hd_line_health_read(&h, 0, 1), HD_LINE_OK); /* 99 failures, then a touch: reset */
    assert_int_equal(h.read_errors[0], 0);
    for (unsigned k = 1; k < 100; k++)
        assert_int_equal(hd_line_health_read(&h, 0, -EIO), HD_LINE_GLITCH);
    assert_int_equal(hd_line_health_read(&h, 0, -ENOENT), HD_LINE_OK); /* unknown line's edge: read worked */
    for (unsigned k = 1; k < 100; k++)
        assert_int_equal(hd_line_health_read(&h, 0, k % 2 ? -EIO : -EAGAIN), HD_LINE_GLITCH);
    assert_false(h.dead[0]);
    assert_int_equal(hd_line_health_read(&h, 0, -EIO), HD_LINE_DISABLED); /* the 100th in a row */
    assert_true(h.dead[0]);
    assert_int_equal(hd_line_health_read(&h, 0, 0), HD_LINE_DISABLED); /* stays disabled */
    /* Line 1 had its own errors interleaved: unaffected. */
    assert_int_equal(hd_line_health_read(&h, 1, -EIO), HD_LINE_GLITCH);
    assert_int_equal(hd_line_health_read(&h, 1, 0), HD_LINE_OK);
    assert_false(h.dead[1]);
    assert_int_equal(hd_line_health_fd_error(&h, 2), HD_LINE_DISABLED);
    assert_true(h.dead[2]);
    assert_int_equal(hd_line_health_read(&h, HD_MAX_LINES, 0), HD_LINE_DISABLED); /* out of range: never a line */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lockout_and_bounce),
        cmocka_unit_test(active_high_and_edges),
        cmocka_unit_test(simultaneous_lines),
        cmocka_unit_test(unknown_line),
        cmocka_unit_test(no_lockout_and_clock_step),
        cmocka_unit_test(host_commands),
        cmocka_unit_test(line_error_policy),
        cmocka_unit_test(host_lines_with_nul_and_long_words),
        cmocka_unit_test(log_escapes_what_is_not_text),
        cmocka_unit_test(log_limit_lets_a_burst_through),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
