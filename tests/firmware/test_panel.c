/* The panel (panel.h) and the program stretched for it
 * (hd_program_set_speed): temperature files read as the kernel writes them,
 * the speed ratio against hand-computed values, its refusals, and the
 * stretched program's frames, exact Gram matrix, peak envelope, lead time
 * and mixer gain. */
#define _GNU_SOURCE
#include "fw_fixture.h"
#include "mixer.h"
#include "panel.h"
#include "program.h"

#include <haptic_stretch.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

static char tmp[256];

static int make_dir(void **state)
{
    (void)state;
    snprintf(tmp, sizeof tmp, "%s/panel-XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    return mkdtemp(tmp) ? 0 : -1;
}

static int remove_dir(void **state)
{
    (void)state;
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmp);
    return system(cmd) == 0 ? 0 : -1;
}

static const char *temp_file(const char *text)
{
    static char path[300];
    snprintf(path, sizeof path, "%s/temp1_input", tmp);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    return path;
}

static void temperature_files_are_read_as_the_kernel_writes_them(void **state)
{
    (void)state;
    char err[HD_ERR_MAX];
    double t = 0;
    assert_int_equal(hd_panel_read_celsius(temp_file("23500\n"), &t, err), 0);
    assert_true(t == 23.5);
    assert_int_equal(hd_panel_read_celsius(temp_file("-4250"), &t, err), 0);
    assert_true(t == -4.25);
    const char *bad[] = {"", "23.5\n", "warm\n", "23500 mC\n", "-300000\n", "1000001\n"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        const char *p = temp_file(bad[i]);
        err[0] = '\0';
        if (hd_panel_read_celsius(p, &t, err) != -EINVAL || strncmp(err, p, strlen(p)) != 0 ||
            !strstr(err, "millidegrees"))
            fail_msg("'%s' taken or badly refused: %s", bad[i], err);
    }
    char missing[300];
    snprintf(missing, sizeof missing, "%s/none", tmp);
    assert_int_equal(hd_panel_read_celsius(missing, &t, err), -ENOENT);
    assert_non_null(strstr(err, missing));
    /* A FIFO (it would block the main thread until a writer came) and a
     * directory: refused at once. */
    char fifo[300];
    snprintf(fifo, sizeof fifo, "%s/fifo", tmp);
    assert_int_equal(mkfifo(fifo, 0600), 0);
    alarm(10);
    assert_int_equal(hd_panel_read_celsius(fifo, &t, err), -EINVAL);
    assert_non_null(strstr(err, "not a regular file"));
    assert_int_equal(hd_panel_read_celsius(tmp, &t, err), -EINVAL);
    alarm(0);
    assert_int_equal(unlink(fifo), 0);
}

static void the_speed_ratio_is_the_boards_times_the_temperatures(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, 2, 1, 8, FW_RANDOM, 1000, 1);
    struct hd_panel_board pb = {.speed_ratio = 1.01};
    char err[HD_ERR_MAX];
    double r = 0;
    /* No sensor: the board's ratio, with or without a panel section. */
    assert_int_equal(hd_panel_speed_ratio(&pb, &t.table, NAN, &r, err), 0);
    assert_true(r == 1.01);
    /* A temperature, or a board with a sensor even before it has read one,
     * needs the table's panel section. */
    assert_int_equal(hd_panel_speed_ratio(&pb, &t.table, 30.0, &r, err), -EINVAL);
    assert_non_null(strstr(err, "no panel section"));
    struct hd_panel_board sensor = pb;
    strcpy(sensor.temperature_input, "/sys/class/hwmon/hwmon0/temp1_input");
    assert_int_equal(hd_panel_speed_ratio(&sensor, &t.table, NAN, &r, err), -EINVAL);
    assert_non_null(strstr(err, "no panel section"));
    const haptic_panel panel = {.temperature_c = 23.0, .youngs_per_k = -0.004};
    t.panel = &panel;
    fw_table_encode(&t, NULL);
    /* +10 K: E x 0.96, waves x sqrt(0.96) = 0.97979590; 1.01 x that = 0.98959386. */
    assert_int_equal(hd_panel_speed_ratio(&pb, &t.table, 33.0, &r, err), 0);
    assert_true(fabs(r - 0.98959386) < 1e-8);
    assert_int_equal(hd_panel_speed_ratio(&pb, &t.table, 23.0, &r, err), 0);
    assert_true(r == 1.01);
    /* -60 K: E x 1.24, waves x 1.11355, x 1.01 = 1.1247: taken. */
    assert_int_equal(hd_panel_speed_ratio(&pb, &t.table, -37.0, &r, err), 0);
    assert_true(fabs(r - 1.01 * sqrt(1.24)) < 1e-12);
    /* 273 C: E would be <= 0; 130 C: sqrt(0.572) x 1.01 = 0.764: both refused, in one line. */
    assert_int_equal(hd_panel_speed_ratio(&pb, &t.table, 273.0, &r, err), -EINVAL);
    assert_non_null(strstr(err, "outside 0.8..1.25"));
    assert_int_equal(hd_panel_speed_ratio(&pb, &t.table, 130.0, &r, err), -EINVAL);
    assert_null(strchr(err, '\n'));
    fw_table_free(&t);
}

/* Brute force, long double: sum over the stretched frames. */
static long double gram_of(const struct hd_program *p, uint32_t i, uint32_t j)
{
    long double acc = 0;
    const int16_t *a = hd_program_signal(p, i), *b = hd_program_signal(p, j);
    for (size_t n = 0; n < (size_t)p->samples * p->channel_count; n++)
        acc += (long double)a[n] * b[n];
    return acc;
}

static void a_stretched_program_plays_the_stretched_drives_with_their_energies(void **state)
{
    (void)state;
    struct fw_table t;
    const uint32_t N = 900, C = 3, K = 3;
    fw_table_make(&t, C, K, N, FW_RANDOM, 9000, 4);
    const double lead[3] = {0.010, 0.012, 0.014};
    fw_table_encode(&t, lead);
    struct hd_board b;
    fw_board(&b, C, HD_FMT_S32_LE, 64);
    struct hd_program *p;
    char err[HD_ERR_MAX];
    assert_int_equal(hd_program_from_table(&t.table, &b, &p, err), 0);
    /* Ratio 1: nothing copied, the table's own drives and Gram matrix. */
    assert_int_equal(hd_program_set_speed(p, 1.0, err), 0);
    assert_null(p->stretched);
    assert_ptr_equal(hd_program_signal(p, 1), haptic_table_signal(&t.table, 1));
    const double r = 1.0125;
    assert_int_equal(hd_program_set_speed(p, r, err), 0);
    assert_int_equal(p->samples, haptic_stretch_frames(N, r));
    assert_int_equal(p->samples, 889); /* ceil(900 / 1.0125) = ceil(888.89) */
    assert_int_equal(p->blocks, (889 + HD_PEAK_BLOCK - 1) / HD_PEAK_BLOCK);
    /* The drives are the stretch of the stored ones. */
    int16_t *want = malloc(sizeof *want * 889 * C);
    for (uint32_t f = 0; f < K; f++) {
        assert_int_equal(haptic_stretch(haptic_table_signal(&t.table, f), N, C, r, want, NULL), 0);
        assert_memory_equal(hd_program_signal(p, f), want, sizeof *want * 889 * C);
    }
    free(want);
    /* The Gram matrix is theirs, exactly (and not the table's). */
    for (uint32_t i = 0; i < K; i++)
        for (uint32_t j = 0; j < K; j++)
            assert_true(hd_program_gram(p, i, j) == (double)gram_of(p, i, j));
    assert_true(hd_program_gram(p, 0, 0) != haptic_table_gram(&t.table, 0, 0));
    /* The mixer's energy normalisation uses them: two foci at E_ref. */
    struct hd_mix m = {.count = 2, .index = {0, 2}};
    assert_int_equal(hd_mixer_gain(p, 1.0, 16.0, &m), 0);
    const long double e_ref = (gram_of(p, 0, 0) + gram_of(p, 2, 2)) / 2,
                      e_sum = gram_of(p, 0, 0) + gram_of(p, 2, 2) + 2 * gram_of(p, 0, 2);
    assert_true(fabs(m.gain_energy - (double)sqrtl(e_ref / e_sum)) < 1e-12);
    /* The envelope bounds the stretched samples block by block. */
    for (uint32_t f = 0; f < K; f++)
        for (uint32_t n = 0; n < p->samples; n++)
            for (uint32_t c = 0; c < C; c++) {
                int v = hd_program_signal(p, f)[(size_t)n * C + c];
                assert_true(abs(v) <= p->block_peak[((size_t)f * p->blocks + n / HD_PEAK_BLOCK) * C + c]);
            }
    /* The focal peak comes r times sooner. */
    assert_true(fabs(hd_program_lead_time_s(p) - 0.014 / r) < 1e-15);
    /* Once per program. */
    assert_int_equal(hd_program_set_speed(p, 0.99, err), -EINVAL);
    assert_non_null(strstr(err, "stretched already"));
    hd_program_free(p);
    assert_int_equal(hd_program_from_table(&t.table, &b, &p, err), 0);
    assert_int_equal(hd_program_set_speed(p, 1.3, err), -EINVAL);
    assert_non_null(strstr(err, "outside 0.8..1.25"));
    /* Refused, it plays the table as stored. */
    assert_null(p->stretched);
    assert_int_equal(p->samples, N);
    assert_ptr_equal(hd_program_signal(p, 2), haptic_table_signal(&t.table, 2));
    assert_true(hd_program_gram(p, 0, 1) == haptic_table_gram(&t.table, 0, 1));
    hd_program_free(p);
    /* A clone is the same table in its own bytes, not stretched. */
    assert_int_equal(hd_program_from_table(&t.table, &b, &p, err), 0);
    assert_int_equal(hd_program_set_speed(p, 0.97, err), 0);
    struct hd_program *q;
    assert_int_equal(hd_program_clone(p, &b, &q, err), 0);
    hd_program_free(p);
    assert_null(q->stretched);
    assert_true(q->table.data != t.table.data);
    assert_memory_equal(hd_program_signal(q, 1), haptic_table_signal(&t.table, 1), sizeof(int16_t) * N * C);
    assert_int_equal(hd_program_find(q, t.ids[2]), 2);
    hd_program_free(q);
    fw_table_free(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(temperature_files_are_read_as_the_kernel_writes_them),
        cmocka_unit_test(the_speed_ratio_is_the_boards_times_the_temperatures),
        cmocka_unit_test(a_stretched_program_plays_the_stretched_drives_with_their_energies),
    };
    return cmocka_run_group_tests(tests, make_dir, remove_dir);
}
