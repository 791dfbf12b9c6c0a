/* Integration with real ALSA: hapticd on the host-sim board (ALSA "file"
 * plugin). Scripted triggers -> the WAV equals the expected mix sample-exactly
 * at the documented alignment; live mode with a FIFO: SIGHUP with a corrupt
 * table is refused and the old table keeps playing, a good table is taken;
 * live triggers rewound in at once leave exactly the sum of the voices in
 * the WAV (and without rewinding start on period boundaries); the user's
 * level, and its clamp into the foci's safe ranges (format 1.3). Live steps wait
 * for what hapticd does (a log line, a voice in the WAV, the FIFO read), not
 * for a time; the one race that is paced by sleeps says why. */
#define _GNU_SOURCE
#include "fw_fixture.h"
#include "hostsim_run.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <sndfile.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#define C 8u
#define N 1000u
#define PERIOD 64u
#define PREFILL 128u /* host-sim: 64 frames x 2 periods */

/* Independent energy-normalized gain for a voice (the peak limit does not
 * bind at these amplitudes: asserted). */
static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Focus f of t as a voice starting at `at` (hs_wait_voice). */
static struct hs_voice voice_of(const struct fw_table *t, uint32_t f, sf_count_t at)
{
    return (struct hs_voice){.at = at, .samples = &t->samples_buf[(size_t)f * N * C], .frames = N};
}

static double ref_gain(const struct fw_table *t, const uint32_t *idx, uint32_t K)
{
    double e_ref = 0, e_sum = 0, peak = 0;
    for (uint32_t n = 0; n < t->samples; n++)
        for (uint32_t c = 0; c < t->channels; c++) {
            double s = 0;
            for (uint32_t k = 0; k < K; k++) {
                e_ref += (double)fw_sample(t, idx[k], n, c) * fw_sample(t, idx[k], n, c) / K;
                s += fw_sample(t, idx[k], n, c);
            }
            e_sum += s * s;
            peak = fmax(peak, fabs(s));
        }
    double g = sqrt(e_ref / e_sum);
    assert_true(g <= 1.0 && g * peak * 1.5 < 32767.0);
    return g;
}

static void scripted(const char *format, const char *map_text, const unsigned *map, int sf_format, double unit)
{
    struct fw_table t;
    fw_table_make(&t, C, 3, N, FW_RANDOM, 6000, 77);
    struct hs_files f;
    hs_files(&f, "plate");
    fw_table_write(&t, f.table);
    hs_write_board(f.board, format, map_text);
    FILE *sf = fopen(f.script, "w");
    /* Frame stamps: 0 (before the pre-fill ends: starts at 128), 4800 (a
     * boundary: starts there), 4810 (starts at the next boundary, 4864, on
     * top of the voice still playing). */
    fprintf(sf, "# test\nat 0 focus %u\nat 4800 foci %u,%u\nat 4810 focus %u\n", t.ids[0], t.ids[1], t.ids[2],
            t.ids[0]);
    fclose(sf);
    char *argv[] = {"hapticd",  "--board", f.board,         "--table", f.table,
                    "--script", f.script,  "--alsa-device", f.device,  NULL};
    pid_t pid = hs_spawn(argv, f.err);
    assert_int_equal(hs_wait_exit(pid), 0);

    sf_count_t frames;
    int32_t *got = hs_read_wav(f.wav, &frames, sf_format);
    const uint32_t starts[3] = {PREFILL, 4800, 4864};
    const uint32_t sets[3][2] = {{0, 0}, {1, 2}, {0, 0}};
    const uint32_t counts[3] = {1, 2, 1};
    double gains[3];
    for (int v = 0; v < 3; v++)
        gains[v] = ref_gain(&t, sets[v], counts[v]);
    assert_true(gains[0] == 1.0);
    /* The run ends at the period boundary after the last voice. */
    assert_int_equal(frames, (4864 + N + PERIOD - 1) / PERIOD * PERIOD);
    long off = 0;
    for (sf_count_t n = 0; n < frames; n++)
        for (uint32_t c = 0; c < C; c++) {
            double y = 0;
            for (int v = 0; v < 3; v++)
                if (n >= starts[v] && n - starts[v] < N)
                    for (uint32_t k = 0; k < counts[v]; k++)
                        y += gains[v] * fw_sample(&t, sets[v][k], (uint32_t)(n - starts[v]), c);
            double want = floor(y * unit + 0.5);
            double have = got[n * C + map[c]];
            if (sf_format == SF_FORMAT_PCM_16)
                have /= 65536.0; /* libsndfile scales 16-bit into the int range */
            if (fabs(have - want) > 1.0)
                fail_msg("frame %ld channel %u: WAV %.0f, expected %.3f", (long)n, c, have, y * unit);
            off += have != want;
        }
    /* K = 1 voices alone are bit-exact; the rest within one LSB of the reference. */
    for (sf_count_t n = PREFILL; n < PREFILL + N; n++)
        for (uint32_t c = 0; c < C; c++) {
            double have = got[n * C + map[c]];
            if (sf_format == SF_FORMAT_PCM_16)
                have /= 65536.0;
            assert_true(have == fw_sample(&t, 0, (uint32_t)(n - PREFILL), c) * unit);
        }
    for (sf_count_t n = 0; n < PREFILL; n++)
        for (uint32_t c = 0; c < C; c++)
            assert_int_equal(got[n * C + c], 0);
    free(got);
    fw_table_free(&t);
    (void)off;
}

static void scripted_s32_identity(void **state)
{
    (void)state;
    const unsigned map[C] = {0, 1, 2, 3, 4, 5, 6, 7};
    scripted("S32_LE", "0,1,2,3,4,5,6,7", map, SF_FORMAT_PCM_32, 65536.0);
}

static void scripted_s16_channel_map(void **state)
{
    (void)state;
    const unsigned map[C] = {3, 1, 7, 5, 0, 2, 4, 6};
    scripted("S16_LE", "3,1,7,5,0,2,4,6", map, SF_FORMAT_PCM_16, 1.0);
}

static void assert_plays(const int32_t *w, sf_count_t at, const struct fw_table *t, uint32_t f)
{
    for (uint32_t n = 0; n < N; n++)
        for (uint32_t c = 0; c < C; c++)
            if (w[(at + n) * C + c] != fw_sample(t, f, n, c) * 65536)
                fail_msg("frame %ld+%u channel %u: %d, table says %d", (long)at, n, c, w[(at + n) * C + c] / 65536,
                         fw_sample(t, f, n, c));
}

static void sighup_keeps_old_table_on_corruption(void **state)
{
    (void)state;
    struct fw_table old_t, new_t;
    fw_table_make(&old_t, C, 2, N, FW_RANDOM, 5000, 1);
    fw_table_make(&new_t, C, 2, N, FW_RANDOM, 5000, 2); /* same ids, other signals */
    struct hs_files f;
    hs_files(&f, "live");
    fw_table_write(&old_t, f.table);
    hs_write_board(f.board, "S32_LE", "0,1,2,3,4,5,6,7");
    int fd;
    const double t0 = now_s();
    pid_t pid = hs_start_live(&f, 0, &fd);
    /* Each voice played whole before the next step: the voices never
     * overlap, and each one's table is the one before the step. */
    hs_send_focus(fd, old_t.ids[0]);
    sf_count_t at = hs_wait_voice(f.wav, 0, N, NULL, 0);
    /* A corrupt table (one payload byte flipped, CRC now wrong) on disk + SIGHUP. */
    old_t.buf[old_t.size - 100] ^= 0x5a;
    fw_table_write(&old_t, f.table);
    old_t.buf[old_t.size - 100] ^= 0x5a;
    kill(pid, SIGHUP);
    hs_wait_for(f.err, "reload refused");
    hs_send_focus(fd, old_t.ids[1]);
    at = hs_wait_voice(f.wav, at + N, N, NULL, 0);
    /* A good new table is taken (handed over before it says so). */
    fw_table_write(&new_t, f.table);
    kill(pid, SIGHUP);
    hs_wait_for(f.err, "reloaded");
    hs_send_focus(fd, new_t.ids[0]);
    hs_wait_voice(f.wav, at + N, N, NULL, 0);
    kill(pid, SIGTERM);
    hs_assert_clean_exit(pid, f.err);
    const double t1 = now_s();
    close(fd);
    assert_true(hs_file_contains(f.err, "stopping (drain)"));

    sf_count_t frames;
    int32_t *w = hs_read_wav(f.wav, &frames, SF_FORMAT_PCM_32);
    sf_count_t a = hs_onset(w, frames, 0);
    assert_true(a >= 0); /* live: at once (a rewind may reach back into the pre-fill) */
    assert_plays(w, a, &old_t, 0);
    sf_count_t b = hs_onset(w, frames, a + N);
    assert_true(b > a);
    assert_plays(w, b, &old_t, 1); /* the refused reload changed nothing */
    sf_count_t c = hs_onset(w, frames, b + N);
    assert_true(c > b);
    assert_plays(w, c, &new_t, 0); /* the good reload took effect */
    assert_int_equal(hs_onset(w, frames, c + N), -1);
    /* Clock pacing: never more frames than the wall time the run took (and
     * the buffer written ahead) allows; a loaded machine only makes fewer. */
    assert_true(frames <= (sf_count_t)((t1 - t0) * 48000.0) + 2 * PREFILL);
    free(w);
    fw_table_free(&old_t);
    fw_table_free(&new_t);
}

/* Live FIFO triggers, the second one while the first voice still plays.
 * With rewinding the queued frames are rendered again with the new voice in
 * them: the WAV must be exactly voice A at a plus voice B at b (the frames
 * of A written twice are identical), and the starts are not tied to the
 * period grid. Without rewinding (board rewind = false) both start on
 * period boundaries, as before. */
static void live_triggers(int rewind)
{
    struct fw_table t;
    fw_table_make(&t, C, 2, N, FW_RANDOM, 5000, 9);
    struct hs_files f;
    hs_files(&f, "rw");
    fw_table_write(&t, f.table);
    hs_write_board_extra(f.board, "S32_LE", "0,1,2,3,4,5,6,7", rewind ? "rewind = true\n" : "rewind = false\n");
    int fd;
    pid_t pid = hs_start_live(&f, 1, &fd);
    enum { triggers = 6 };
    struct hs_voice heard[triggers];
    sf_count_t from = 0;
    for (int i = 0; i < triggers; i++) {
        /* Pairs: B is sent as soon as A's first frame is in the WAV, so it
         * starts while A (20.8 ms) plays, and never in the same period as A
         * (which would merge them into one voice), however loaded the
         * machine; the next pair once B has played. */
        hs_send_focus(fd, t.ids[i % 2]);
        from = hs_wait_voice(f.wav, from, i % 2 ? N : 1, heard, (size_t)i);
        heard[i] = voice_of(&t, (uint32_t)i % 2, from);
        from++;
    }
    kill(pid, SIGTERM);
    hs_assert_clean_exit(pid, f.err);
    close(fd);
    assert_true(hs_file_contains(f.err, rewind ? "triggers start at once" : "rewind = false"));
    assert_int_equal(hs_report_value(f.report, "triggers"), triggers);
    /* The fixed part of touch -> focal peak: 32 of 48000 frames kept ahead of a
     * rewound voice, else the 128-frame buffer; the table has no lead time. */
    assert_true(hs_file_contains(f.report, rewind ? "queue_ahead_ms 0.667\n" : "queue_ahead_ms 2.667\n"));
    assert_true(hs_file_contains(f.report, "lead_time_ms unknown\n"));
    assert_true(hs_file_contains(f.err, rewind ? "queue 0.667 ms (rewind margin)" : "queue 2.667 ms (no rewinding"));
    long rewinds = hs_report_value(f.report, "rewinds");
    if (rewind)
        assert_true(rewinds >= 1 && rewinds <= triggers); /* a late audio thread may leave none to rewind */
    else
        assert_int_equal(rewinds, 0);

    sf_count_t frames;
    int32_t *w = hs_read_wav(f.wav, &frames, SF_FORMAT_PCM_32);
    int32_t *rest = malloc((size_t)frames * C * sizeof *rest);
    memcpy(rest, w, (size_t)frames * C * sizeof *rest);
    from = 0;
    int off_grid = 0;
    for (int v = 0; v < triggers; v++) {
        /* A voice's onset: the first frame the voices found so far do not explain. */
        sf_count_t at = hs_onset(rest, frames, from);
        assert_true(at >= 0 && at + N <= frames);
        for (uint32_t n = 0; n < N; n++)
            for (uint32_t c = 0; c < C; c++)
                rest[(at + n) * C + c] -= fw_sample(&t, (uint32_t)v % 2, n, c) * 65536;
        if (!rewind)
            assert_int_equal(at % PERIOD, 0);
        off_grid += at % PERIOD != 0;
        /* Voices start in trigger order, where they were heard while it ran
         * (how far apart depends on the machine: not asserted). */
        if (v > 0)
            assert_true(at > from);
        assert_int_equal(at, heard[v].at);
        from = at;
    }
    /* Nothing else: every frame is exactly the sum of the voices found. */
    assert_int_equal(hs_onset(rest, frames, 0), -1);
    if (rewind)
        assert_true(off_grid >= 1); /* 6 starts all on the 64-frame grid by chance: 64^-6 */
    free(rest);
    free(w);
    fw_table_free(&t);
}

static void live_rewind_starts_at_once(void **state)
{
    (void)state;
    live_triggers(1);
}

static void live_without_rewind_starts_at_period(void **state)
{
    (void)state;
    live_triggers(0);
}

/* Waits (10 s at most) until the WAV hapticd is writing has had a voice and
 * then `frames` silent frames on end; returns the first of them. */
static sf_count_t wait_quiet(const char *wav, sf_count_t frames)
{
    for (int i = 0; i < 1000; i++) {
        sf_count_t n;
        int32_t *w = hs_wav_snapshot(wav, &n);
        sf_count_t end = n; /* one past the last non-zero frame */
        while (end > 0) {
            uint32_t c = 0;
            while (c < C && !w[(end - 1) * C + c])
                c++;
            if (c < C)
                break;
            end--;
        }
        free(w);
        if (end > 0 && n - end >= frames)
            return end;
        hs_sleep_ms(10);
    }
    fail_msg("%s never went quiet for %ld frames after a voice", wav, (long)frames);
    return -1;
}

/* Signals racing the audio thread: triggers flow from the FIFO while SIGHUP
 * reloads the table twice, and SIGTERM arrives while the last voice plays,
 * so the main thread reloads, collects and waits for the drain while the
 * audio thread renders. Under ThreadSanitizer (the tsan preset) a data race
 * between them makes hapticd exit 66; in every build the drain must let the
 * voice in flight finish: the WAV ends with the last voice complete. */
static void live_signals_race_the_audio_thread(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 2, N, FW_RANDOM, 5000, 13);
    struct hs_files f;
    hs_files(&f, "race");
    fw_table_write(&t, f.table);
    hs_write_board(f.board, "S32_LE", "0,1,2,3,4,5,6,7");
    int fd;
    pid_t pid = hs_start_live(&f, 1, &fd);
    const int triggers = 40;
    for (int i = 0; i < triggers - 1; i++) {
        hs_send_focus(fd, t.ids[i % 2]);
        if (i == 10 || i == 25)
            kill(pid, SIGHUP); /* same file: a good table, taken while voices play */
        /* The race itself: triggers 3 ms apart, so voices overlap (and may
         * merge) while the reloads are taken. A pace, not a wait: nothing
         * asserted depends on where the triggers fall. */
        hs_sleep_ms(3);
    }
    /* The last trigger alone, so its voice is not merged with another and
     * starts after every other: once hapticd has read every trigger before
     * it and the WAV has gone quiet after their voices. */
    hs_wait_fifo_read(fd);
    const sf_count_t quiet = wait_quiet(f.wav, N + 2 * PREFILL);
    hs_send_focus(fd, t.ids[(triggers - 1) % 2]);
    hs_wait_voice(f.wav, quiet, 1, NULL, 0);
    /* SIGTERM as soon as the last voice (20.8 ms) is heard starting: it is
     * still playing, and the drain must let it finish. (A machine so loaded
     * that it ended meanwhile leaves the drain nothing to do; what is
     * asserted below holds either way.) */
    kill(pid, SIGTERM);
    hs_assert_clean_exit(pid, f.err);
    close(fd);
    assert_false(hs_file_contains(f.err, "ThreadSanitizer"));
    assert_true(hs_file_contains(f.err, "stopping (drain)"));
    assert_true(hs_file_contains(f.err, "reloaded"));
    assert_int_equal(hs_report_value(f.report, "triggers"), triggers);

    /* Drained: the last frames of the WAV are the end of the last voice,
     * which started after every other one; find it from the end. */
    sf_count_t frames;
    int32_t *w = hs_read_wav(f.wav, &frames, SF_FORMAT_PCM_32);
    sf_count_t last = -1;
    for (sf_count_t n = frames - 1; n >= 0 && last < 0; n--)
        for (uint32_t c = 0; c < C; c++)
            if (w[n * C + c]) {
                last = n;
                break;
            }
    assert_true(last >= N);
    /* The last non-zero frame closes a voice: it is the table's last
     * non-zero frame of one focus, N - 1 frames after that voice's start
     * (the voices before it ended earlier, the table never ends in zeros). */
    uint32_t focus = (uint32_t)(triggers - 1) % 2;
    for (uint32_t c = 0; c < C; c++)
        if (w[last * C + c] != fw_sample(&t, focus, N - 1, c) * 65536)
            fail_msg("last non-zero frame %ld of %ld, channel %u: %d, the last voice ends with %d", (long)last,
                     (long)frames, c, w[last * C + c] / 65536, fw_sample(&t, focus, N - 1, c));
    free(w);
    fw_table_free(&t);
}

/* The user's intensity file, live: the level written before the start plays
 * the first voice at 10^(-6/20) of the table (to one LSB of the Q30 gain);
 * a new level is taken for the next voice; a bad value is refused once and
 * the level kept; a table reload keeps it too. */
static void intensity_file_sets_the_level(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 2, N, FW_RANDOM, 5000, 29);
    struct hs_files f;
    hs_files(&f, "level");
    fw_table_write(&t, f.table);
    char level[300], extra[400];
    hs_path(level, sizeof level, "intensity_db");
    snprintf(extra, sizeof extra, "[control]\nintensity_file = %s\n", level);
    hs_write_board_extra(f.board, "S32_LE", "0,1,2,3,4,5,6,7", extra);
    FILE *lf = fopen(level, "w");
    fputs("-6\n", lf);
    fclose(lf);
    int fd;
    pid_t pid = hs_start_live(&f, 0, &fd);
    assert_true(hs_file_contains(f.err, "intensity -6.0 dB"));
    const double g[] = {pow(10.0, -6.0 / 20.0), 1.0, 1.0, 1.0};
    sf_count_t from = 0, onset[4];
    for (int i = 0; i < 4; i++) {
        if (i == 1) { /* 0 dB, through a rename as an editor would */
            char tmp[320];
            snprintf(tmp, sizeof tmp, "%s.new", level);
            lf = fopen(tmp, "w");
            fputs("0\n", lf);
            fclose(lf);
            assert_int_equal(rename(tmp, level), 0);
            hs_wait_for(f.err, "intensity +0.0 dB");
        } else if (i == 2) { /* a bad value: refused, the level stays */
            lf = fopen(level, "w");
            fputs("loud\n", lf);
            fclose(lf);
            hs_wait_for(f.err, "is not a number of dB");
        } else if (i == 3) { /* a reload keeps it */
            kill(pid, SIGHUP);
            hs_wait_for(f.err, "reloaded");
        }
        hs_send_focus(fd, t.ids[0]);
        from = hs_wait_voice(f.wav, from, N, NULL, 0);
        onset[i] = from;
        from += N;
    }
    kill(pid, SIGTERM);
    hs_assert_clean_exit(pid, f.err);
    close(fd);
    assert_int_equal(hs_file_count(f.err, "is not a number of dB"), 1);
    sf_count_t frames;
    int32_t *w = hs_read_wav(f.wav, &frames, SF_FORMAT_PCM_32);
    for (int i = 0; i < 4; i++)
        for (uint32_t n = 0; n < N; n++)
            for (uint32_t c = 0; c < C; c++) {
                const double want = g[i] * fw_sample(&t, 0, n, c) * 65536.0;
                const double got = w[(onset[i] + n) * C + c];
                if (fabs(got - want) > 65536.0)
                    fail_msg("voice %d frame %u channel %u: %.0f, want %.0f", i, n, c, got, want);
            }
    free(w);
    fw_table_free(&t);
}

/* Independent of hapticd: the gain a focus of safe range [lo, hi) plays at
 * for the level asked, as docs/firmware.md states it. */
static double clamped(double lo, double hi, double level)
{
    const double top = hi * (1 - 1e-6);
    return level < lo ? (lo < top ? lo : top) : level < top ? level : top;
}

/* frames [at, at + N) of the WAV hold `gain` times focus f of t (two foci
 * summed when f2 >= 0), to one S32 LSB (the Q30 gain's rounding). */
static void assert_plays_at(const int32_t *w, sf_count_t at, const struct fw_table *t, uint32_t f, int f2, double gain,
                            const char *what)
{
    for (uint32_t n = 0; n < N; n++)
        for (uint32_t c = 0; c < C; c++) {
            const double s = fw_sample(t, f, n, c) + (f2 >= 0 ? fw_sample(t, (uint32_t)f2, n, c) : 0);
            const double want = gain * s * 65536.0, got = w[(at + n) * C + c];
            if (fabs(got - want) > 1.0)
                fail_msg("%s: frame %ld+%u channel %u: %.0f, want %.1f (gain %.9g)", what, (long)at, n, c, got, want,
                         gain);
        }
}

/* hapticd with argv (a --check), its stdout into hs_dir/name (path in out)
 * and its stderr into out + ".err"; the exit status. */
static int check_into(char *const argv[], const char *name, char *out, size_t cap)
{
    hs_path(out, cap, name);
    char err[320];
    snprintf(err, sizeof err, "%s.err", out);
    return hs_wait_exit(hs_spawn_out(argv, out, err));
}

/* A table with the foci's safe ranges (format 1.3), scripted at the level
 * 0 dB: focus 0's range [1.25, 2) lies above it (it plays at +1.9 dB), focus
 * 1's [0.25, 0.5) below (it plays at its top, 0.5 (1 - 1e-6)); both
 * together play at the top of the intersection [1.25, 0.5), which holds no
 * gain. The clamp is logged once, in one line, and --check shows it. */
static void scripted_safe_range_clamps_the_level(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 2, N, FW_RANDOM, 5000, 61);
    const haptic_gain_range r[2] = {{1.25, 2.0}, {0.25, 0.5}};
    const haptic_range_spec spec = {1e-6, HAPTIC_RANGE_WHOLE_AREA, r};
    t.range = &spec;
    fw_table_encode(&t, NULL);
    struct hs_files f;
    hs_files(&f, "range");
    fw_table_write(&t, f.table);
    hs_write_board_extra(f.board, "S32_LE", "0,1,2,3,4,5,6,7", "[mixer]\ngain_limit = 4\n");
    FILE *sf = fopen(f.script, "w");
    fprintf(sf, "at 0 focus %u\nat 4800 focus %u\nat 9600 foci %u,%u\n", t.ids[0], t.ids[1], t.ids[0], t.ids[1]);
    fclose(sf);
    char *argv[] = {"hapticd",  "--board", f.board,         "--table", f.table,
                    "--script", f.script,  "--alsa-device", f.device,  NULL};
    assert_int_equal(hs_wait_exit(hs_spawn(argv, f.err)), 0);
    assert_int_equal(hs_file_count(f.err, "intensity "), 1); /* one line */
    assert_true(hs_file_contains(f.err, "intensity +0.0 dB: above the safe range of 1 of 2 foci (tops -6.0..-6.0 "
                                        "dB): they play at their tops; below the safe range of 1 of 2 foci (bottoms "
                                        "+1.9..+1.9 dB): they play at their bottoms"));
    sf_count_t frames;
    int32_t *w = hs_read_wav(f.wav, &frames, SF_FORMAT_PCM_32);
    assert_int_equal(frames, (9600 + N + PERIOD - 1) / PERIOD * PERIOD);
    assert_plays_at(w, PREFILL, &t, 0, -1, clamped(1.25, 2.0, 1.0), "focus 0 at its bottom");
    assert_plays_at(w, 4800, &t, 1, -1, clamped(0.25, 0.5, 1.0), "focus 1 at its top");
    assert_plays_at(w, 9600, &t, 0, 1, clamped(1.25, 0.5, 1.0), "both at the intersection's top");
    free(w);
    /* --check: the summary's range. */
    char *check[] = {"hapticd", "--check", f.table, NULL};
    char out[300];
    assert_int_equal(check_into(check, "range-check.txt", out, sizeof out), 0);
    assert_true(hs_file_contains(out, "format 1.3"));
    assert_true(hs_file_contains(out, "range        threshold 1 um over the whole active area (scope 1)"));
    assert_true(hs_file_contains(out, "safe +1.9..+6.0 dB\n"));
    assert_true(hs_file_contains(out, "safe -12.0..-6.0 dB\n"));
    fw_table_free(&t);
}

/* `hapticd --check TABLE --board BOARD`: what each focus costs the board's
 * exciters, against energies computed here from the samples. Every sample
 * of the constant table is `amp` on every channel but exciter 3's, 2 amp:
 * the busiest, one touch puts N (2 amp)^2 (V / 32767)^2 / Z / rate joules
 * into its coil, adds that over
 * tau to its heat, and the rating sustains P / that touches a second; at
 * the top of a focus's safe range, the top's square times as much. A board
 * without ratings, or one the table does not fit, is refused in one line. */
static void check_with_a_board_reports_the_exciters_cost(void **state)
{
    (void)state;
    const int amp = 1000;
    struct fw_table t;
    fw_table_make(&t, C, 2, N, FW_CONSTANT, amp, 1);
    for (size_t i = 3; i < (size_t)2 * N * C; i += C) /* exciter 3 the busiest: twice the amplitude */
        t.samples_buf[i] = 2 * amp;
    const haptic_gain_range r[2] = {{0.5, 2.0}, {0.25, INFINITY}};
    const haptic_range_spec spec = {1e-6, HAPTIC_RANGE_WHOLE_AREA, r};
    t.range = &spec;
    fw_table_encode(&t, NULL);
    struct hs_files f;
    hs_files(&f, "exciters");
    fw_table_write(&t, f.table);
    hs_write_board_extra(f.board, "S32_LE", "0,1,2,3,4,5,6,7",
                         "[exciters]\nrated_power_w = 2\nimpedance_ohm = 8\nthermal_tau_s = 0.5\n"
                         "[amplifier]\nfull_scale_v = 10\n");
    char out[300];
    char *argv[] = {"hapticd", "--check", f.table, "--board", f.board, NULL};
    assert_int_equal(check_into(argv, "exciters-check.txt", out, sizeof out), 0);
    size_t len;
    char *text = hs_slurp(out, &len);
    const double v = 10.0 / 32767.0, joules = (double)N * (2 * amp) * (2 * amp) * v * v / 8.0 / 48000.0;
    for (uint32_t k = 0; k < 2; k++) {
        char head[96];
        snprintf(head, sizeof head, "  focus %u: exciter 3 (2 W rated, tau 0.5 s): ", t.ids[k]);
        const char *line = strstr(text, head);
        if (!line)
            fail_msg("no line '%s' in:\n%s", head, text);
        double mj, mw, hz, top_db, top_mj, top_hz;
        assert_int_equal(sscanf(line + strlen(head),
                                "%lf mJ a touch, heat +%lf mW, %lf touches/s; at the top of "
                                "its safe range (%lf dB) %lf mJ, %lf touches/s",
                                &mj, &mw, &hz, &top_db, &top_mj, &top_hz),
                         k == 0 ? 6 : 3);
        assert_true(fabs(mj / (1e3 * joules) - 1) < 1e-3);
        assert_true(fabs(mw / (1e3 * joules / 0.5) - 1) < 1e-3);
        assert_true(fabs(hz / (2.0 / joules) - 1) < 1e-3);
        if (k == 0) { /* the top: 2 (1 - 1e-6), +6.0 dB */
            assert_true(fabs(top_db - 6.0) < 0.05);
            assert_true(fabs(top_mj / (1e3 * joules * 4) - 1) < 1e-3);
            assert_true(fabs(top_hz / (2.0 / joules / 4) - 1) < 1e-3);
        } else { /* unbounded: no top to report */
            assert_non_null(strstr(line, "touches/s; its safe range has no top\n"));
        }
    }
    free(text);
    /* A board without ratings; a board of another channel count. */
    hs_write_board(f.board, "S32_LE", "0,1,2,3,4,5,6,7");
    assert_int_equal(check_into(argv, "exciters-none.txt", out, sizeof out), 1);
    char err[320];
    snprintf(err, sizeof err, "%s.err", out);
    assert_int_equal(hs_file_count(err, "\n"), 1);
    assert_true(hs_file_contains(err, "no [exciters] ratings to compare the drives with"));
    hs_write_board_extra(f.board, "S32_LE", "0,1,2,3",
                         "[exciters]\nrated_power_w = 2\nimpedance_ohm = 8\n"
                         "[amplifier]\nfull_scale_v = 10\n");
    assert_int_equal(check_into(argv, "exciters-channels.txt", out, sizeof out), 1);
    snprintf(err, sizeof err, "%s.err", out);
    assert_int_equal(hs_file_count(err, "\n"), 1);
    fw_table_free(&t);
}

/* Live, with the user's intensity file at +8 dB: a table without a range
 * section plays the level as ever and says nothing of ranges; SIGHUP to the
 * same drives with ranges ([0.5, 2) and [0.25, +inf)): focus 0 now plays at
 * its top, focus 1 at the level, and the reload says so in one line; -30 dB:
 * both below their ranges, said in one line, focus 0 plays at its bottom. */
static void live_level_is_clamped_into_the_safe_range(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 2, N, FW_RANDOM, 5000, 67);
    struct hs_files f;
    hs_files(&f, "range-live");
    fw_table_write(&t, f.table);
    char level[300], extra[400];
    hs_path(level, sizeof level, "range_intensity_db");
    snprintf(extra, sizeof extra, "[control]\nintensity_file = %s\n[mixer]\ngain_limit = 4\n", level);
    hs_write_board_extra(f.board, "S32_LE", "0,1,2,3,4,5,6,7", extra);
    fw_write_text(level, "+8\n");
    int fd;
    pid_t pid = hs_start_live(&f, 0, &fd);
    assert_true(hs_file_contains(f.err, "intensity +8.0 dB\n"));
    const double up = pow(10.0, 8.0 / 20.0), down = pow(10.0, -30.0 / 20.0);
    struct {
        uint32_t focus;
        double gain;
    } voices[4];
    sf_count_t onset[4], from = 0;
    for (int i = 0; i < 4; i++) {
        if (i == 1) {
            const haptic_gain_range r[2] = {{0.5, 2.0}, {0.25, INFINITY}};
            const haptic_range_spec spec = {1e-6, HAPTIC_RANGE_WHOLE_AREA, r};
            t.range = &spec;
            fw_table_encode(&t, NULL);
            fw_table_write(&t, f.table);
            t.range = NULL;
            kill(pid, SIGHUP);
            hs_wait_for(f.err, "intensity +8.0 dB: above the safe range of 1 of 2 foci (tops +6.0..+6.0 dB): they "
                               "play at their tops");
        } else if (i == 3) {
            fw_write_text(level, "-30\n");
            hs_wait_for(f.err, "intensity -30.0 dB: below the safe range of 2 of 2 foci (bottoms -12.0..-6.0 dB): "
                               "they play at their bottoms");
        }
        voices[i].focus = i == 2;
        voices[i].gain = i == 0   ? up
                         : i == 1 ? clamped(0.5, 2.0, up)
                         : i == 2 ? clamped(0.25, INFINITY, up)
                                  : clamped(0.5, 2.0, down);
        hs_send_focus(fd, t.ids[voices[i].focus]);
        from = hs_wait_voice(f.wav, from, N, NULL, 0);
        onset[i] = from;
        from += N;
    }
    kill(pid, SIGTERM);
    hs_assert_clean_exit(pid, f.err);
    close(fd);
    assert_int_equal(hs_file_count(f.err, "safe range"), 2); /* once after the reload, once for -30 dB */
    assert_int_equal(hs_file_count(f.err, "intensity "), 3); /* the start's +8 dB, then those two */
    assert_true(voices[1].gain < 2.0 && voices[2].gain == up && voices[3].gain == 0.5);
    sf_count_t frames;
    int32_t *w = hs_read_wav(f.wav, &frames, SF_FORMAT_PCM_32);
    const char *what[4] = {"no range: the level", "focus 0 at its top", "focus 1 at the level",
                           "focus 0 at its bottom"};
    for (int i = 0; i < 4; i++)
        assert_plays_at(w, onset[i], &t, voices[i].focus, -1, voices[i].gain, what[i]);
    free(w);
    fw_table_free(&t);
}

static void bad_inputs_fail_cleanly(void **state)
{
    (void)state;
    struct hs_files f;
    hs_files(&f, "bad");
    /* Bad script line: one-line error naming the file and the line. */
    FILE *sf = fopen(f.script, "w");
    fprintf(sf, "at 0 focus 1\nat 10 wiggle 3\n");
    fclose(sf);
    struct fw_table t;
    fw_table_make(&t, C, 1, 64, FW_RANDOM, 100, 3);
    fw_table_write(&t, f.table);
    char *argv1[] = {"hapticd",  "--board", HOSTSIM_BOARD,   "--table", f.table,
                     "--script", f.script,  "--alsa-device", "null",    NULL};
    assert_int_equal(hs_wait_exit(hs_spawn(argv1, f.err)), 1);
    char want[400];
    snprintf(want, sizeof want, "%s:2: unknown command 'wiggle'", f.script);
    assert_true(hs_file_contains(f.err, want));
    /* A corrupt table at start: refused, named. */
    t.buf[t.size - 10] ^= 1;
    fw_table_write(&t, f.table);
    char *argv2[] = {"hapticd", "--board", HOSTSIM_BOARD, "--table", f.table, "--script", f.script, NULL};
    assert_int_equal(hs_wait_exit(hs_spawn(argv2, f.err)), 1);
    assert_true(hs_file_contains(f.err, "crc32"));
    assert_true(hs_file_contains(f.err, f.table));
    char *argv3[] = {"hapticd", "--check", f.table, NULL};
    assert_int_equal(hs_wait_exit(hs_spawn(argv3, f.err)), 1);
    t.buf[t.size - 10] ^= 1;
    fw_table_write(&t, f.table);
    assert_int_equal(hs_wait_exit(hs_spawn(argv3, f.err)), 0);
    /* --rt-priority is range-checked in its full width: 2^32 + 80 used to be
     * narrowed to 80 and accepted. */
    char *argv4[] = {"hapticd", "--board", HOSTSIM_BOARD, "--table", f.table, "--rt-priority", "4294967376", NULL};
    assert_int_equal(hs_wait_exit(hs_spawn(argv4, f.err)), 2);
    assert_true(hs_file_contains(f.err, "--rt-priority: '4294967376' is not in 0..99"));
    char *argv5[] = {"hapticd", "--board", HOSTSIM_BOARD, "--table", f.table, "--rt-priority", "", NULL};
    assert_int_equal(hs_wait_exit(hs_spawn(argv5, f.err)), 2);
    /* A FIFO as the table: refused at once, not blocked on (the suite's
     * timeout would end a hang). */
    char fifo[400];
    snprintf(fifo, sizeof fifo, "%s.fifo", f.table);
    assert_int_equal(mkfifo(fifo, 0600), 0);
    char *argv6[] = {"hapticd", "--check", fifo, NULL};
    assert_int_equal(hs_wait_exit(hs_spawn(argv6, f.err)), 1);
    assert_true(hs_file_contains(f.err, "not a regular file"));
    assert_int_equal(unlink(fifo), 0);
    fw_table_free(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(scripted_s32_identity),
        cmocka_unit_test(scripted_s16_channel_map),
        cmocka_unit_test(sighup_keeps_old_table_on_corruption),
        cmocka_unit_test(live_rewind_starts_at_once),
        cmocka_unit_test(live_without_rewind_starts_at_period),
        cmocka_unit_test(live_signals_race_the_audio_thread),
        cmocka_unit_test(intensity_file_sets_the_level),
        cmocka_unit_test(scripted_safe_range_clamps_the_level),
        cmocka_unit_test(check_with_a_board_reports_the_exciters_cost),
        cmocka_unit_test(live_level_is_clamped_into_the_safe_range),
        cmocka_unit_test(bad_inputs_fail_cleanly),
    };
    return cmocka_run_group_tests(tests, hs_setup, hs_teardown);
}
