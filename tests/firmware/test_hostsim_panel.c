/* The speed compensation live, on real ALSA (host-sim): hapticd plays a
 * table stretched by the board's speed ratio; when the panel's temperature
 * file moves by the step it plays the table stretched for the new
 * temperature (the table's panel section: 23 C, dE/E/dT -0.4 %/K), sample
 * for sample what common/haptic_stretch.h gives; an unreadable sensor is
 * logged and the table keeps playing as it was; a table without a panel
 * section is refused at start when the board has a sensor. */
#define _GNU_SOURCE
#include "fw_fixture.h"
#include "hostsim_run.h"

#include <haptic_stretch.h>

#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#define C HS_CHANNELS
#define N 1000u

static void set_temperature(const char *file, const char *text)
{
    char tmp[320];
    snprintf(tmp, sizeof tmp, "%s.new", file);
    FILE *f = fopen(tmp, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    assert_int_equal(rename(tmp, file), 0); /* the daemon never reads half a file */
}

/* The voice at `at` is focus f of `t` stretched by `ratio`; returns its length. */
static uint32_t assert_plays_stretched(const int32_t *w, sf_count_t frames, sf_count_t at, const struct fw_table *t,
                                       uint32_t f, double ratio)
{
    const uint32_t m = haptic_stretch_frames(N, ratio);
    int16_t *want = malloc(sizeof *want * m * C);
    assert_int_equal(haptic_stretch(&t->samples_buf[(size_t)f * N * C], N, C, ratio, want, NULL), 0);
    assert_true(at + m <= frames);
    for (uint32_t n = 0; n < m; n++)
        for (uint32_t c = 0; c < C; c++)
            if (w[(at + n) * C + c] != want[(size_t)n * C + c] * 65536)
                fail_msg("ratio %.6f frame %ld+%u channel %u: %d, stretched table says %d", ratio, (long)at, n, c,
                         w[(at + n) * C + c] / 65536, want[(size_t)n * C + c]);
    free(want);
    return m;
}

static void the_table_follows_the_panel_temperature(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 2, N, FW_RANDOM, 6000, 21);
    const haptic_panel panel = {.temperature_c = 23.0, .youngs_per_k = -0.004};
    t.panel = &panel;
    fw_table_encode(&t, NULL);
    char table[300], fifo[300], wav[300], board[300], err[300], device[400], temp[300], extra[700];
    hs_path(table, sizeof table, "panel.htab");
    hs_path(fifo, sizeof fifo, "panel-triggers");
    hs_path(wav, sizeof wav, "panel.wav");
    hs_path(board, sizeof board, "panel.ini");
    hs_path(err, sizeof err, "panel-stderr.txt");
    hs_path(temp, sizeof temp, "temp1_input");
    fw_table_write(&t, table);
    set_temperature(temp, "23000\n");
    snprintf(extra, sizeof extra,
             "[panel]\nspeed_ratio = 1.01\ntemperature_input = %s\ntemperature_poll_s = 0.05\n"
             "temperature_step_k = 0.5\n", temp);
    hs_write_board_extra(board, "S32_LE", "0,1,2,3,4,5,6,7", extra);
    unlink(fifo);
    assert_int_equal(mkfifo(fifo, 0600), 0);
    snprintf(device, sizeof device, "hostsim:FILE=\"%s\"", wav);
    char *argv[] = {"hapticd", "--board", board, "--table", table, "--triggers", fifo, "--alsa-device", device, NULL};
    pid_t pid = hs_spawn(argv, err);
    int fd = open(fifo, O_WRONLY);
    assert_true(fd >= 0);
    hs_wait_for(err, "running");
    assert_true(hs_file_contains(err, "drives played 1.01000 times as fast"));
    hs_send_focus(fd, t.ids[0]);
    hs_sleep_ms(100);
    /* +10 K: E x 0.96, waves x sqrt(0.96). 0.3 K is below the step: nothing. */
    set_temperature(temp, "23300\n");
    hs_sleep_ms(200);
    assert_false(hs_file_contains(err, "stretching again"));
    set_temperature(temp, "33000\n");
    hs_wait_for(err, "panel temperature 33.00 C (the table is stretched for 23.00 C): stretching again");
    hs_wait_for(err, "reloaded");
    hs_send_focus(fd, t.ids[1]);
    hs_sleep_ms(100);
    /* The sensor fails: logged once, the table stays as it is. */
    set_temperature(temp, "n/a\n");
    hs_wait_for(err, "panel temperature unreadable, the table stays stretched for 33.00 C");
    hs_send_focus(fd, t.ids[1]);
    hs_sleep_ms(100);
    kill(pid, SIGTERM);
    hs_assert_clean_exit(pid, err);
    close(fd);

    sf_count_t frames;
    int32_t *w = hs_read_wav(wav, &frames, SF_FORMAT_PCM_32);
    const double hot = 1.01 * sqrt(0.96);
    sf_count_t a = hs_onset(w, frames, 0);
    assert_true(a >= 0);
    uint32_t m = assert_plays_stretched(w, frames, a, &t, 0, 1.01);
    sf_count_t b = hs_onset(w, frames, a + m);
    assert_true(b > a);
    m = assert_plays_stretched(w, frames, b, &t, 1, hot);
    assert_int_equal(m, 1011); /* ceil(1000 / 0.98959) */
    sf_count_t c = hs_onset(w, frames, b + m);
    assert_true(c > b);
    m = assert_plays_stretched(w, frames, c, &t, 1, hot);
    assert_int_equal(hs_onset(w, frames, c + m), -1);
    free(w);

    /* A sensor without the table's panel section: refused at start, in one line. */
    t.panel = NULL;
    fw_table_encode(&t, NULL);
    fw_table_write(&t, table);
    set_temperature(temp, "23000\n");
    char *argv2[] = {"hapticd", "--board", board, "--table", table, "--triggers", fifo, "--alsa-device", device, NULL};
    assert_int_equal(hs_wait_exit(hs_spawn(argv2, err)), 1);
    assert_true(hs_file_contains(err, "[panel] temperature_input: the table has no panel section"));
    fw_table_free(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(the_table_follows_the_panel_temperature),
    };
    return cmocka_run_group_tests(tests, hs_setup, hs_teardown);
}
