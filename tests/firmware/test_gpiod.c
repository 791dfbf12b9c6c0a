/* libgpiod v1 shim with -Wl,--wrap mocks: lines requested for both edges with
 * their bias (active-low handled by the state machine), edge events read and
 * mapped to foci, read errors handled, open failures named. */
#include "trigger_gpiod.h"

#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <cmocka.h>

static int chip_token, line_tokens[HD_MAX_LINES];
static unsigned requested_offsets[HD_MAX_LINES];
static struct gpiod_line_request_config requested[HD_MAX_LINES];
static int nrequested, nreleased, nclosed;
static int fail_lookup, fail_request_at = -1;
static struct {
    int rc, err;
    struct gpiod_line_event ev;
} events[16];
static int nevents, next_event;

struct gpiod_chip *__wrap_gpiod_chip_open_lookup(const char *descr)
{
    assert_string_equal(descr, "gpiochip0");
    if (fail_lookup) {
        errno = ENOENT;
        return NULL;
    }
    return (struct gpiod_chip *)&chip_token;
}
struct gpiod_line *__wrap_gpiod_chip_get_line(struct gpiod_chip *chip, unsigned int offset)
{
    assert_ptr_equal(chip, &chip_token);
    requested_offsets[nrequested] = offset;
    return (struct gpiod_line *)&line_tokens[nrequested];
}
int __wrap_gpiod_line_request(struct gpiod_line *line, const struct gpiod_line_request_config *cfg, int default_val)
{
    (void)default_val;
    assert_ptr_equal(line, &line_tokens[nrequested]);
    if (nrequested == fail_request_at) {
        errno = EBUSY;
        return -1;
    }
    requested[nrequested++] = *cfg;
    return 0;
}
int __wrap_gpiod_line_event_get_fd(struct gpiod_line *line) { return 100 + (int)((int *)line - line_tokens); }
int __wrap_gpiod_line_event_read(struct gpiod_line *line, struct gpiod_line_event *ev)
{
    (void)line;
    assert_true(next_event < nevents);
    int i = next_event++;
    if (events[i].rc) {
        errno = events[i].err;
        return -1;
    }
    *ev = events[i].ev;
    return 0;
}
void __wrap_gpiod_line_release(struct gpiod_line *line)
{
    (void)line;
    nreleased++;
}
void __wrap_gpiod_chip_close(struct gpiod_chip *chip)
{
    assert_ptr_equal(chip, &chip_token);
    nclosed++;
}

static void board(struct hd_board *b)
{
    hd_board_defaults(b);
    strcpy(b->path, "boards/rpi5-dac8x/board.ini");
    strcpy(b->gpio_chip, "gpiochip0");
    b->lockout_ms = 50;
    b->line_count = 2;
    b->lines[0] =
        (struct hd_line){.offset = 17, .active_low = true, .bias = HD_BIAS_PULL_UP, .focus_count = 1, .focus_ids = {3}};
    b->lines[1] = (struct hd_line){.offset = 27, .bias = HD_BIAS_PULL_DOWN, .focus_count = 2, .focus_ids = {1, 4}};
}

static int reset(void **state)
{
    (void)state;
    nrequested = nreleased = nclosed = nevents = next_event = 0;
    fail_lookup = 0;
    fail_request_at = -1;
    memset(events, 0, sizeof events);
    return 0;
}

static void add_event(int type, long sec, long nsec)
{
    events[nevents].ev.event_type = type;
    events[nevents].ev.ts.tv_sec = sec;
    events[nevents].ev.ts.tv_nsec = nsec;
    nevents++;
}

static void requests_and_events(void **state)
{
    (void)state;
    struct hd_board b;
    board(&b);
    struct hd_gpio g;
    char err[HD_ERR_MAX];
    assert_int_equal(hd_gpio_open(&g, &b, err), 0);
    assert_int_equal(g.count, 2);
    assert_int_equal(requested_offsets[0], 17);
    assert_int_equal(requested_offsets[1], 27);
    for (int i = 0; i < 2; i++) {
        assert_string_equal(requested[i].consumer, "hapticd");
        assert_int_equal(requested[i].request_type, GPIOD_LINE_REQUEST_EVENT_BOTH_EDGES);
    }
    assert_int_equal(requested[0].flags, GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_UP); /* no ACTIVE_LOW to the kernel */
    assert_int_equal(requested[1].flags, GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_DOWN);
    assert_int_equal(g.fds[0], 100);
    assert_int_equal(g.fds[1], 101);

    struct hd_trigger t;
    hd_trigger_init(&t, &b);
    struct hd_event ev;
    add_event(GPIOD_LINE_EVENT_FALLING_EDGE, 5, 0);      /* press on active-low 17 */
    add_event(GPIOD_LINE_EVENT_RISING_EDGE, 5, 1000000); /* bounce */
    add_event(GPIOD_LINE_EVENT_RISING_EDGE, 5, 2000000); /* press on active-high 27 */
    events[nevents].rc = -1;                             /* read error */
    events[nevents++].err = EIO;
    add_event(GPIOD_LINE_EVENT_FALLING_EDGE, 5, 100000000); /* 17 again after its lockout */
    assert_int_equal(hd_gpio_read(&g, 0, &t, &ev), 1);
    assert_int_equal(ev.focus_count, 1);
    assert_int_equal(ev.focus_ids[0], 3);
    assert_int_equal(hd_gpio_read(&g, 0, &t, &ev), 0);
    assert_int_equal(hd_gpio_read(&g, 1, &t, &ev), 1);
    assert_int_equal(ev.focus_count, 2);
    assert_int_equal(ev.focus_ids[1], 4);
    assert_int_equal(hd_gpio_read(&g, 1, &t, &ev), -EIO);
    assert_int_equal(g.read_errors, 1);
    assert_int_equal(hd_gpio_read(&g, 0, &t, &ev), 1); /* the line keeps working */
    assert_int_equal(hd_gpio_read(&g, 7, &t, &ev), -EINVAL);
    hd_gpio_close(&g);
    assert_int_equal(nreleased, 2);
    assert_int_equal(nclosed, 1);
}

static void open_failures(void **state)
{
    (void)state;
    struct hd_board b;
    board(&b);
    struct hd_gpio g;
    char err[HD_ERR_MAX] = "";
    fail_lookup = 1;
    assert_int_equal(hd_gpio_open(&g, &b, err), -ENOENT);
    assert_non_null(strstr(err, "gpiochip0"));
    assert_non_null(strstr(err, "boards/rpi5-dac8x/board.ini"));
    reset(NULL);
    fail_request_at = 1;
    assert_int_equal(hd_gpio_open(&g, &b, err), -EBUSY);
    assert_non_null(strstr(err, "line 27"));
    assert_non_null(strstr(err, "boards/rpi5-dac8x/board.ini"));
    assert_null(strchr(err, '\n'));
    assert_int_equal(nreleased, 1); /* the line already requested is released */
    assert_int_equal(nclosed, 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(requests_and_events, reset),
        cmocka_unit_test_setup(open_failures, reset),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
