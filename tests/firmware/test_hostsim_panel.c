/* The speed compensation live, on real ALSA (host-sim): hapticd plays a
 * table stretched by the board's speed ratio (a sensor that cannot be read
 * yet at start is not fatal); when the panel's temperature file moves by the
 * step it plays the table stretched for the new temperature (the table's
 * panel section: 23 C, dE/E/dT -0.4 %/K), sample for sample what
 * common/haptic_stretch.h gives, from the table that plays (a new file on
 * disk waits for SIGHUP); a temperature beyond the stretch's range is refused
 * once, an unreadable sensor is logged once, and the table keeps playing as
 * it was; a table without a panel section is refused at start when the
 * board has a sensor. */
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

/* How many times `needle` occurs in the file. */
static int count_in(const char *file, const char *needle)
{
    static char buf[1 << 16];
    FILE *fp = fopen(file, "r");
    if (!fp)
        return 0;
    size_t n = fread(buf, 1, sizeof buf - 1, fp);
    fclose(fp);
    buf[n] = '\0';
    int k = 0;
    for (const char *p = buf; (p = strstr(p, needle)) != NULL; p++)
        k++;
    return k;
}

static void the_table_follows_the_panel_temperature(void **state)
{
    (void)state;
    struct fw_table t, other;
    fw_table_make(&t, C, 2, N, FW_RANDOM, 6000, 21);
    fw_table_make(&other, C, 2, N, FW_RANDOM, 6000, 22); /* same ids, other drives */
    const haptic_panel panel = {.temperature_c = 23.0, .youngs_per_k = -0.004};
    t.panel = other.panel = &panel;
    fw_table_encode(&t, NULL);
    fw_table_encode(&other, NULL);
    char temp[300], extra[700];
    struct hs_files f;
    hs_files(&f, "panel");
    hs_path(temp, sizeof temp, "temp1_input");
    fw_table_write(&t, f.table);
    unlink(temp); /* the sensor's driver has not probed yet */
    snprintf(extra, sizeof extra,
             "[panel]\nspeed_ratio = 1.01\ntemperature_input = %s\ntemperature_poll_s = 0.2\n"
             "temperature_step_k = 0.5\n", temp);
    hs_write_board_extra(f.board, "S32_LE", "0,1,2,3,4,5,6,7", extra);
    int fd;
    pid_t pid = hs_start_live(&f, 0, &fd);
    /* No temperature yet: the board's ratio alone. */
    assert_true(hs_file_contains(f.err, "the table plays at the board's speed ratio until it can be read"));
    assert_true(hs_file_contains(f.err, "drives played 1.01000 times as fast as stored (board speed ratio 1.01000),"));
    hs_send_focus(fd, t.ids[0]);
    hs_sleep_ms(100);
    /* The sensor appears at the calibration temperature: the same ratio, handed over again. */
    set_temperature(temp, "23000\n");
    hs_wait_for(f.err, "panel temperature 23.00 C: stretching the table for it");
    hs_wait_for(f.err, "re-stretched");
    /* 0.3 K is below the step: nothing for three polls. */
    set_temperature(temp, "23300\n");
    hs_sleep_ms(700);
    assert_false(hs_file_contains(f.err, "stretching again"));
    /* +10 K: E x 0.96, waves x sqrt(0.96). */
    set_temperature(temp, "33000\n");
    hs_wait_for(f.err, "panel temperature 33.00 C (the table is stretched for 23.00 C): stretching again");
    hs_sleep_ms(100);
    hs_send_focus(fd, t.ids[1]);
    hs_sleep_ms(100);
    /* A new table on disk without SIGHUP: a temperature step stretches the
     * table that plays, not the file. */
    fw_table_write(&other, f.table);
    set_temperature(temp, "38000\n");
    hs_wait_for(f.err, "panel temperature 38.00 C (the table is stretched for 33.00 C): stretching again");
    hs_sleep_ms(100);
    hs_send_focus(fd, t.ids[1]);
    hs_sleep_ms(100);
    /* 200 C: E x 0.292, a ratio of 0.546: refused once, not tried again at every poll. */
    set_temperature(temp, "200000\n");
    hs_wait_for(f.err, "panel at 200.00 C: the table keeps playing as it is");
    hs_sleep_ms(700);
    assert_int_equal(count_in(f.err, "panel at 200.00 C: the table keeps playing as it is"), 1);
    /* The sensor fails: logged once, the table stays as it is. */
    set_temperature(temp, "n/a\n");
    hs_wait_for(f.err, "panel temperature unreadable, the table keeps playing as it is");
    hs_sleep_ms(500);
    assert_int_equal(count_in(f.err, "panel temperature unreadable"), 1);
    hs_send_focus(fd, t.ids[0]);
    hs_sleep_ms(100);
    kill(pid, SIGTERM);
    hs_assert_clean_exit(pid, f.err);
    close(fd);

    sf_count_t frames;
    int32_t *w = hs_read_wav(f.wav, &frames, SF_FORMAT_PCM_32);
    const double hot = 1.01 * sqrt(0.96), hotter = 1.01 * sqrt(1 - 0.004 * 15);
    const struct { uint32_t focus; double ratio; } voices[] = {{0, 1.01}, {1, hot}, {1, hotter}, {0, hotter}};
    sf_count_t at = 0;
    for (int v = 0; v < 4; v++) {
        at = hs_onset(w, frames, at);
        assert_true(at >= 0);
        const uint32_t m = assert_plays_stretched(w, frames, at, &t, voices[v].focus, voices[v].ratio);
        if (v == 1)
            assert_int_equal(m, 1011); /* ceil(1000 / 0.98959) */
        at += m;
    }
    assert_int_equal(hs_onset(w, frames, at), -1);
    free(w);

    /* A sensor without the table's panel section: refused at start, in one line. */
    t.panel = NULL;
    fw_table_encode(&t, NULL);
    fw_table_write(&t, f.table);
    set_temperature(temp, "23000\n");
    char *argv2[] = {"hapticd", "--board", f.board, "--table", f.table, "--triggers", f.fifo,
                     "--alsa-device", f.device, NULL};
    assert_int_equal(hs_wait_exit(hs_spawn(argv2, f.err)), 1);
    assert_true(hs_file_contains(f.err, "[panel] temperature_input: the table has no panel section"));
    fw_table_free(&t);
    fw_table_free(&other);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(the_table_follows_the_panel_temperature),
    };
    return cmocka_run_group_tests(tests, hs_setup, hs_teardown);
}
