/* The speed compensation live, on real ALSA (host-sim): hapticd plays a
 * table stretched by the board's speed ratio (a sensor that cannot be read
 * yet at start is not fatal); when the panel's temperature file moves by the
 * step it plays the table stretched for the new temperature (the table's
 * panel section: 23 C, dE/E/dT -0.4 %/K), sample for sample what
 * common/haptic_stretch.h gives, from the table that plays (a new file on
 * disk waits for SIGHUP); a temperature beyond the stretch's range is refused
 * once, an unreadable sensor is logged once, and the table keeps playing as
 * it was; a table without a panel section is refused at start when the
 * board has a sensor. Every step waits for what hapticd does (a log line, a
 * voice in the WAV, its reads of the temperature file seen through inotify),
 * never for a time. */
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
#include <sys/inotify.h>
#include <sys/stat.h>
#include <unistd.h>

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#define C HS_CHANNELS
#define N 1000u

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

/* hapticd's reads of the temperature file: inotify on its folder reports
 * each time a reader closes it (the daemon opens it read-only at each poll;
 * the test itself only writes a new file and renames it in). */
static int watch_reads(void)
{
    int fd = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    assert_true(fd >= 0);
    assert_true(inotify_add_watch(fd, hs_dir, IN_CLOSE_NOWRITE) >= 0);
    return fd;
}

/* Waits (10 s at most) until hapticd has read the file `name` k more times.
 * A poll acts on what it read before the next one reads again, so after
 * two reads the first one's outcome is in the log. */
static void wait_reads(int fd, const char *name, int k)
{
    _Alignas(struct inotify_event) char buf[4096];
    for (int i = 0; i < 1000 && k > 0; i++) {
        ssize_t n;
        while ((n = read(fd, buf, sizeof buf)) > 0)
            for (char *p = buf; p < buf + n;) {
                const struct inotify_event *ev = (const struct inotify_event *)p;
                if (ev->len && !strcmp(ev->name, name))
                    k--;
                p += sizeof *ev + ev->len;
            }
        if (k > 0)
            hs_sleep_ms(10);
    }
    if (k > 0)
        fail_msg("hapticd did not read %s %d more times within 10 s", name, k);
}

/* Forgets the reads seen so far. */
static void forget_reads(int fd)
{
    char buf[4096];
    while (read(fd, buf, sizeof buf) > 0) {
    }
}

/* Triggers focus `id` and waits until its voice, played `ratio` times as
 * fast as stored, is in the WAV whole, after frame `from`; returns the frame
 * after it. Each voice played whole before the next step: voices never
 * overlap, and each one's stretch is the one in force when it was sent. */
static sf_count_t play(int fd, const char *wav, uint32_t id, sf_count_t from, double ratio)
{
    hs_send_focus(fd, id);
    const sf_count_t m = haptic_stretch_frames(N, ratio);
    return hs_wait_voice(wav, from, m, NULL, 0) + m;
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
    const double hot = 1.01 * sqrt(0.96), hotter = 1.01 * sqrt(1 - 0.004 * 15);
    char temp[300], extra[700];
    struct hs_files f;
    hs_files(&f, "panel");
    hs_path(temp, sizeof temp, "temp1_input");
    fw_table_write(&t, f.table);
    unlink(temp); /* the sensor's driver has not probed yet */
    snprintf(extra, sizeof extra,
             "[panel]\nspeed_ratio = 1.01\ntemperature_input = %s\ntemperature_poll_s = 0.2\n"
             "temperature_step_k = 0.5\n",
             temp);
    hs_write_board_extra(f.board, "S32_LE", "0,1,2,3,4,5,6,7", extra);
    int reads = watch_reads();
    int fd;
    pid_t pid = hs_start_live(&f, 0, &fd);
    /* No temperature yet: the board's ratio alone. */
    assert_true(hs_file_contains(f.err, "the table plays at the board's speed ratio until it can be read"));
    assert_true(hs_file_contains(f.err, "drives played 1.01000 times as fast as stored (board speed ratio 1.01000),"));
    sf_count_t end = play(fd, f.wav, t.ids[0], 0, 1.01);
    /* The sensor appears at the calibration temperature: the same ratio, handed over again. */
    fw_write_text(temp, "23000\n");
    hs_wait_for(f.err, "panel temperature 23.00 C: stretching the table for it");
    hs_wait_count(f.err, "re-stretched", 1);
    /* 0.3 K is below the step: nothing for three polls. */
    forget_reads(reads);
    fw_write_text(temp, "23300\n");
    wait_reads(reads, "temp1_input", 3);
    assert_false(hs_file_contains(f.err, "stretching again"));
    /* +10 K: E x 0.96, waves x sqrt(0.96); handed over once it says so. */
    fw_write_text(temp, "33000\n");
    hs_wait_for(f.err, "panel temperature 33.00 C (the table is stretched for 23.00 C): stretching again");
    hs_wait_count(f.err, "re-stretched", 2);
    end = play(fd, f.wav, t.ids[1], end, hot);
    /* A new table on disk without SIGHUP: a temperature step stretches the
     * table that plays, not the file. */
    fw_table_write(&other, f.table);
    fw_write_text(temp, "38000\n");
    hs_wait_for(f.err, "panel temperature 38.00 C (the table is stretched for 33.00 C): stretching again");
    hs_wait_count(f.err, "re-stretched", 3);
    end = play(fd, f.wav, t.ids[1], end, hotter);
    /* 200 C: E x 0.292, a ratio of 0.546: refused once, not tried again at every poll. */
    fw_write_text(temp, "200000\n");
    hs_wait_for(f.err, "panel at 200.00 C: the table keeps playing as it is");
    forget_reads(reads);
    wait_reads(reads, "temp1_input", 3);
    assert_int_equal(hs_file_count(f.err, "panel at 200.00 C: the table keeps playing as it is"), 1);
    /* The sensor fails: logged once, the table stays as it is. */
    fw_write_text(temp, "n/a\n");
    hs_wait_for(f.err, "panel temperature unreadable, the table keeps playing as it is");
    forget_reads(reads);
    wait_reads(reads, "temp1_input", 3);
    assert_int_equal(hs_file_count(f.err, "panel temperature unreadable"), 1);
    play(fd, f.wav, t.ids[0], end, hotter);
    kill(pid, SIGTERM);
    hs_assert_clean_exit(pid, f.err);
    close(fd);
    close(reads);

    sf_count_t frames;
    int32_t *w = hs_read_wav(f.wav, &frames, SF_FORMAT_PCM_32);
    const struct {
        uint32_t focus;
        double ratio;
    } voices[] = {{0, 1.01}, {1, hot}, {1, hotter}, {0, hotter}};
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
    fw_write_text(temp, "23000\n");
    char *argv2[] = {"hapticd",    "--board", f.board,         "--table", f.table,
                     "--triggers", f.fifo,    "--alsa-device", f.device,  NULL};
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
