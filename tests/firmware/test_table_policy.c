/* The table policy (table_policy.h) on its own, with a real engine whose
 * audio thread is played by the test (hd_engine_period), a table file and a
 * temperature file in a scratch folder, and hd_log captured (--wrap): a
 * reload keeps the table playing on a bad file and stretches a good one for
 * the current temperature; a temperature step stretches the table that
 * plays (not the file) again; a sensor that fails leaves the table as it is
 * and is logged once; a temperature the table cannot be stretched for is
 * refused once and not tried again until the panel is a step away from it. */
#define _GNU_SOURCE
#include "engine.h"
#include "fw_fixture.h"
#include "table_policy.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#define C 8u
#define N 1000u
#define PERIOD 64u

/* ---- hd_log, captured ---- */

static char logged[1 << 16];
static size_t logged_len;

void __wrap_hd_log(int priority, const char *fmt, ...);
void __wrap_hd_log(int priority, const char *fmt, ...)
{
    (void)priority;
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(logged + logged_len, sizeof logged - logged_len - 1, fmt, ap);
    va_end(ap);
    assert_true(n >= 0 && (size_t)n < sizeof logged - logged_len - 1);
    logged_len += (size_t)n;
    logged[logged_len++] = '\n';
    logged[logged_len] = '\0';
}

static unsigned log_count(const char *needle)
{
    unsigned k = 0;
    for (const char *p = logged; (p = strstr(p, needle)) != NULL; p += strlen(needle))
        k++;
    return k;
}

/* ---- the scratch folder, the table and the sensor ---- */

static char dir[256], table_path[300], sensor_path[300];

static int make_dir(void **state)
{
    (void)state;
    const char *tmp = getenv("TMPDIR");
    snprintf(dir, sizeof dir, "%s/table-policy-XXXXXX", tmp && *tmp ? tmp : "/tmp");
    if (!mkdtemp(dir))
        return -1;
    snprintf(table_path, sizeof table_path, "%s/plate.htab", dir);
    snprintf(sensor_path, sizeof sensor_path, "%s/temp1_input", dir);
    return 0;
}

static int remove_dir(void **state)
{
    (void)state;
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* The table's panel section: calibrated at 23 C, dE/E/dT = -0.4 %/K. */
static const haptic_panel panel = {.temperature_c = 23.0, .youngs_per_k = -0.004};

static void make_table(struct fw_table *t, uint32_t seed, int with_panel)
{
    fw_table_make(t, C, 2, N, FW_RANDOM, 6000, seed);
    if (with_panel) {
        t->panel = &panel;
        fw_table_encode(t, NULL);
    }
}

/* A board with speed ratio 1.01 and, when `sensor`, the temperature file
 * read every 0.2 s with a 0.5 K step. */
static void make_board(struct hd_board *b, int sensor)
{
    fw_board(b, C, HD_FMT_S32_LE, PERIOD);
    b->panel.speed_ratio = 1.01;
    if (sensor) {
        snprintf(b->panel.temperature_input, sizeof b->panel.temperature_input, "%s", sensor_path);
        b->panel.temperature_poll_s = 0.2;
        b->panel.temperature_step_k = 0.5;
    }
}

/* The speed ratio the panel plays at `celsius` (panel.h). */
static double ratio_at(double celsius)
{
    return 1.01 * sqrt(1.0 + panel.youngs_per_k * (celsius - panel.temperature_c));
}

/* ---- the daemon around the policy ---- */

struct rig {
    struct fw_table t; /* the table file at start */
    struct hd_board board;
    struct hd_engine engine;
    struct hd_table_policy tp;
    struct hd_program *first;
    unsigned handed;               /* calls of the hand-over hook */
    const struct hd_program *last; /* the program it was given */
};

static void on_handed_over(void *ctx, const struct hd_program *p)
{
    struct rig *r = ctx;
    r->handed++;
    r->last = p;
}

/* Table t (seed; a panel section when `panel_section`) on disk, the board
 * (its sensor when `sensor`, reading `celsius`, or not there yet when
 * NULL); opens the policy at time 0 and starts the engine on its first
 * table. */
static void rig_start(struct rig *r, uint32_t seed, int panel_section, int sensor, const char *celsius)
{
    make_table(&r->t, seed, panel_section);
    fw_table_write(&r->t, table_path);
    make_board(&r->board, sensor);
    if (celsius)
        fw_write_text(sensor_path, celsius);
    else
        unlink(sensor_path);
    logged_len = 0;
    logged[0] = '\0';
    r->handed = 0;
    r->last = NULL;
    char err[HD_ERR_MAX];
    if (hd_table_policy_open(&r->tp, &r->board, table_path, 0.0, &r->first, err) != 0)
        fail_msg("%s", err);
    assert_ptr_equal(r->tp.latest, r->first);
    assert_int_equal(hd_engine_init(&r->engine, &r->board, r->first, 0), 0);
    hd_table_policy_attach(&r->tp, &r->engine, on_handed_over, r);
}

static void rig_end(struct rig *r)
{
    hd_engine_free(&r->engine);
    fw_table_free(&r->t);
}

/* The audio thread's part: two periods take the offered table and retire
 * the one before (no voice plays). */
static void audio_takes_over(struct rig *r)
{
    static int32_t out[PERIOD * C];
    hd_engine_period(&r->engine, out, PERIOD);
    hd_engine_period(&r->engine, out, PERIOD);
    assert_null(atomic_load(&r->engine.next));
    assert_ptr_equal(r->engine.current, r->tp.latest);
}

/* Nothing was offered since the last take-over, and the playing table is `p`. */
static void assert_nothing_offered(struct rig *r, const struct hd_program *p)
{
    assert_null(atomic_load(&r->engine.next));
    assert_ptr_equal(r->tp.latest, p);
    assert_ptr_equal(r->engine.current, p);
}

/* A poll that is due: the sensor is read (the next reading is due a
 * temperature_poll_s later). Returns what hd_table_policy_poll returned. */
static int poll_due(struct rig *r, double now_s)
{
    int rc = hd_table_policy_poll(&r->tp, now_s);
    assert_true(r->tp.next_poll_s == now_s + r->board.panel.temperature_poll_s);
    return rc;
}

/* The program plays the drives of table t (as stored, before any stretch). */
static void assert_table_of(const struct hd_program *p, const struct fw_table *t)
{
    for (uint32_t f = 0; f < t->foci; f++)
        assert_memory_equal(haptic_table_signal(&p->table, f), &t->samples_buf[(size_t)f * N * C],
                            (size_t)N * C * sizeof(int16_t));
}

/* ---- the cases ---- */

/* SIGHUP: a corrupt file and a missing one are refused, nothing is offered
 * and the first table keeps playing; a good file is handed over (and to the
 * hook) and plays. Without a sensor the board's speed ratio alone. */
static void reload_keeps_the_old_table_on_a_bad_file(void **state)
{
    (void)state;
    struct rig r;
    rig_start(&r, 1, 0, 0, NULL);
    struct fw_table other;
    make_table(&other, 2, 0); /* same ids, other drives */
    assert_true(r.first->speed_ratio == 1.01);
    assert_table_of(r.first, &r.t);

    r.t.buf[r.t.size - 100] ^= 0x5a; /* a payload byte: the CRC no longer holds */
    fw_table_write(&r.t, table_path);
    r.t.buf[r.t.size - 100] ^= 0x5a;
    assert_true(hd_table_policy_reload(&r.tp) < 0);
    assert_int_equal(log_count("reload refused, the current table keeps playing: "), 1);
    assert_int_equal(log_count("crc32"), 1);
    assert_nothing_offered(&r, r.first);
    assert_int_equal(r.handed, 0);

    assert_int_equal(unlink(table_path), 0);
    assert_true(hd_table_policy_reload(&r.tp) < 0);
    assert_int_equal(log_count("reload refused"), 2);
    assert_nothing_offered(&r, r.first);

    fw_table_write(&other, table_path);
    assert_int_equal(hd_table_policy_reload(&r.tp), 0);
    const struct hd_program *p = atomic_load(&r.engine.next);
    assert_non_null(p);
    assert_ptr_equal(r.tp.latest, p);
    assert_int_equal(r.handed, 1);
    assert_ptr_equal(r.last, p);
    assert_table_of(p, &other);
    assert_true(p->speed_ratio == 1.01);
    char want[400];
    snprintf(want, sizeof want, "reloaded %s (2 foci, 8 channels, %u samples)", table_path, p->samples);
    assert_int_equal(log_count(want), 1);
    audio_takes_over(&r);
    rig_end(&r);
    fw_table_free(&other);
}

/* The sensor read at start sets the first stretch; a reading is taken only
 * when due; less than temperature_step_k either way changes nothing; a step
 * or more stretches the table that plays again, even with another table on
 * disk (which SIGHUP then loads, stretched for the temperature of the
 * moment). */
static void a_temperature_step_restretches(void **state)
{
    (void)state;
    struct rig r;
    rig_start(&r, 3, 1, 1, "23000\n");
    struct fw_table other;
    make_table(&other, 4, 1);
    assert_true(r.tp.celsius == 23.0);
    assert_true(r.first->speed_ratio == 1.01); /* the calibration temperature: the board's ratio */
    assert_false(r.tp.sensor_failing);

    fw_write_text(sensor_path, "33000\n");
    assert_int_equal(hd_table_policy_poll(&r.tp, 0.19), 0); /* not due: not read */
    assert_nothing_offered(&r, r.first);
    assert_int_equal(poll_due(&r, 0.2), 1);
    assert_int_equal(log_count("panel temperature 33.00 C (the table is stretched for 23.00 C): stretching again"), 1);
    const struct hd_program *hot = atomic_load(&r.engine.next);
    assert_non_null(hot);
    assert_ptr_equal(r.tp.latest, hot);
    assert_ptr_equal(r.last, hot);
    assert_int_equal(r.handed, 1);
    assert_true(fabs(hot->speed_ratio - ratio_at(33.0)) < 1e-12);
    assert_true(r.tp.celsius == 33.0);
    assert_table_of(hot, &r.t);
    audio_takes_over(&r);

    fw_write_text(sensor_path, "33300\n"); /* 0.3 K: below the step */
    assert_int_equal(poll_due(&r, 1.0), 0);
    fw_write_text(sensor_path, "32600\n"); /* 0.4 K the other way */
    assert_int_equal(poll_due(&r, 2.0), 0);
    assert_nothing_offered(&r, hot);
    assert_true(r.tp.celsius == 33.0);
    fw_write_text(sensor_path, "33500\n"); /* a step exactly */
    assert_int_equal(poll_due(&r, 3.0), 1);
    assert_true(r.tp.celsius == 33.5);
    audio_takes_over(&r);

    /* Another table on disk, no SIGHUP: the step stretches the one that plays. */
    fw_table_write(&other, table_path);
    fw_write_text(sensor_path, "38000\n");
    assert_int_equal(poll_due(&r, 4.0), 1);
    assert_int_equal(log_count("panel temperature 38.00 C (the table is stretched for 33.50 C): stretching again"), 1);
    const struct hd_program *hotter = atomic_load(&r.engine.next);
    assert_non_null(hotter);
    assert_table_of(hotter, &r.t);
    assert_true(fabs(hotter->speed_ratio - ratio_at(38.0)) < 1e-12);
    assert_int_equal(log_count("re-stretched"), 3);
    audio_takes_over(&r);

    /* SIGHUP now: the file, stretched for 38 C. */
    assert_int_equal(hd_table_policy_reload(&r.tp), 0);
    const struct hd_program *reloaded = atomic_load(&r.engine.next);
    assert_non_null(reloaded);
    assert_table_of(reloaded, &other);
    assert_true(fabs(reloaded->speed_ratio - ratio_at(38.0)) < 1e-12);
    assert_true(r.tp.celsius == 38.0);
    assert_int_equal(r.handed, 4);
    audio_takes_over(&r);
    rig_end(&r);
    fw_table_free(&other);
}

/* A sensor that cannot be read at start is not fatal (the board's ratio);
 * once readable the table is stretched for it; when it fails again the table
 * stays as it is, logged once however many polls it stays failed, and once
 * again only after it was readable in between. */
static void a_sensor_failure_keeps_the_table(void **state)
{
    (void)state;
    struct rig r;
    rig_start(&r, 5, 1, 1, NULL); /* the sensor's driver has not probed yet */
    assert_int_equal(log_count("the table plays at the board's speed ratio until it can be read"), 1);
    assert_true(isnan(r.tp.celsius));
    assert_true(r.tp.sensor_failing);
    assert_true(r.first->speed_ratio == 1.01);
    assert_int_equal(poll_due(&r, 0.2), 0);
    assert_int_equal(log_count("panel temperature unreadable"), 0); /* said at start already */
    assert_nothing_offered(&r, r.first);

    fw_write_text(sensor_path, "25000\n");
    assert_int_equal(poll_due(&r, 1.0), 1);
    assert_int_equal(log_count("panel temperature readable again: 25.00 C"), 1);
    assert_int_equal(log_count("panel temperature 25.00 C: stretching the table for it"), 1);
    assert_false(r.tp.sensor_failing);
    assert_true(r.tp.celsius == 25.0);
    const struct hd_program *p = atomic_load(&r.engine.next);
    assert_true(fabs(p->speed_ratio - ratio_at(25.0)) < 1e-12);
    audio_takes_over(&r);

    fw_write_text(sensor_path, "n/a\n");
    for (int i = 0; i < 4; i++)
        assert_int_equal(poll_due(&r, 2.0 + i), 0);
    assert_int_equal(log_count("panel temperature unreadable, the table keeps playing as it is: "), 1);
    assert_true(r.tp.sensor_failing);
    assert_true(r.tp.celsius == 25.0);
    assert_nothing_offered(&r, p);
    assert_int_equal(r.handed, 1);

    fw_write_text(sensor_path, "25200\n"); /* readable, within the step: nothing to do */
    assert_int_equal(poll_due(&r, 6.0), 0);
    assert_int_equal(log_count("panel temperature readable again: 25.20 C"), 1);
    fw_write_text(sensor_path, "n/a\n");
    assert_int_equal(poll_due(&r, 7.0), 0);
    assert_int_equal(log_count("panel temperature unreadable"), 2); /* a new failing stretch */
    assert_nothing_offered(&r, p);
    rig_end(&r);
}

/* 200 C asks a ratio of 0.546, beyond the stretch: refused once, logged
 * once, not tried again within a step of it; a step from it is tried (and
 * refused) again; a temperature that can be played is handed over and
 * clears the memory, so 200 C is tried once more when it comes back. */
static void a_refused_temperature_is_not_tried_again(void **state)
{
    (void)state;
    struct rig r;
    rig_start(&r, 6, 1, 1, "23000\n");
    assert_true(isnan(r.tp.refused_celsius));

    fw_write_text(sensor_path, "200000\n");
    assert_true(poll_due(&r, 0.2) < 0);
    assert_int_equal(log_count("panel at 200.00 C: the table keeps playing as it is: "), 1);
    assert_true(r.tp.refused_celsius == 200.0);
    assert_true(r.tp.celsius == 23.0);
    assert_nothing_offered(&r, r.first);
    for (int i = 0; i < 3; i++)
        assert_int_equal(poll_due(&r, 1.0 + i), 0);
    fw_write_text(sensor_path, "200300\n"); /* within a step of the refused one */
    assert_int_equal(poll_due(&r, 4.0), 0);
    assert_int_equal(log_count("the table keeps playing as it is"), 1);

    fw_write_text(sensor_path, "201000\n"); /* a step from it: tried, refused again */
    assert_true(poll_due(&r, 5.0) < 0);
    assert_int_equal(log_count("panel at 201.00 C: the table keeps playing as it is"), 1);
    assert_true(r.tp.refused_celsius == 201.0);
    assert_nothing_offered(&r, r.first);
    assert_int_equal(r.handed, 0);

    fw_write_text(sensor_path, "24000\n");
    assert_int_equal(poll_due(&r, 6.0), 1);
    assert_true(isnan(r.tp.refused_celsius));
    assert_true(r.tp.celsius == 24.0);
    audio_takes_over(&r);
    fw_write_text(sensor_path, "200000\n");
    assert_true(poll_due(&r, 7.0) < 0);
    assert_int_equal(log_count("panel at 200.00 C: the table keeps playing as it is"), 2);
    rig_end(&r);
}

/* No sensor: polling never reads anything nor hands anything over. A sensor
 * and a table without a panel section: refused at open, in one line. */
static void without_a_sensor_nothing_moves_and_without_a_panel_section_a_sensor_is_refused(void **state)
{
    (void)state;
    struct rig r;
    rig_start(&r, 7, 0, 0, "40000\n");
    for (int i = 0; i < 5; i++)
        assert_int_equal(hd_table_policy_poll(&r.tp, 100.0 * i), 0);
    assert_nothing_offered(&r, r.first);
    assert_int_equal(log_count("\n"), 1); /* the first table's stretch, nothing else */
    assert_int_equal(log_count("panel: drives played 1.01000 times as fast as stored (board speed ratio 1.01000),"), 1);
    hd_engine_free(&r.engine);

    make_board(&r.board, 1);
    char err[HD_ERR_MAX] = "";
    assert_int_equal(hd_table_policy_open(&r.tp, &r.board, table_path, 0.0, &r.first, err), -EINVAL);
    assert_non_null(strstr(err, "[panel] temperature_input: the table has no panel section"));
    fw_table_free(&r.t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(reload_keeps_the_old_table_on_a_bad_file),
        cmocka_unit_test(a_temperature_step_restretches),
        cmocka_unit_test(a_sensor_failure_keeps_the_table),
        cmocka_unit_test(a_refused_temperature_is_not_tried_again),
        cmocka_unit_test(without_a_sensor_nothing_moves_and_without_a_panel_section_a_sensor_is_refused),
    };
    return cmocka_run_group_tests(tests, make_dir, remove_dir);
}
