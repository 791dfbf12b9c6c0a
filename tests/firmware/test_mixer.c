/* Mixer against a double-precision reference: gain (energy normalization,
 * peak limit), sample values up to rounding, energy, saturation, 1..K foci,
 * channel map, both device formats. The reference recomputes every quantity
 * from the raw samples, not from the table's Gram matrix. */
#define _POSIX_C_SOURCE 200809L
#include "fw_fixture.h"
#include "mixer.h"
#include "player.h"
#include "program.h"

#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#define C 8u
#define N 1000u

struct ref {
    double gain_energy, gain_peak, gain, e_ref;
};

/* Independent gain: energies and block peaks straight from the samples. */
static struct ref ref_gain(const struct fw_table *t, const uint32_t *idx, uint32_t K, double limit)
{
    struct ref r;
    double e_ref = 0.0, e_sum = 0.0;
    for (uint32_t k = 0; k < K; k++)
        for (uint32_t n = 0; n < t->samples; n++)
            for (uint32_t c = 0; c < t->channels; c++)
                e_ref += (double)fw_sample(t, idx[k], n, c) * fw_sample(t, idx[k], n, c);
    e_ref /= K;
    for (uint32_t n = 0; n < t->samples; n++)
        for (uint32_t c = 0; c < t->channels; c++) {
            double s = 0.0;
            for (uint32_t k = 0; k < K; k++)
                s += fw_sample(t, idx[k], n, c);
            e_sum += s * s;
        }
    double peak = 0.0;
    for (uint32_t b0 = 0; b0 < t->samples; b0 += HD_PEAK_BLOCK)
        for (uint32_t c = 0; c < t->channels; c++) {
            double s = 0.0;
            for (uint32_t k = 0; k < K; k++) {
                double m = 0.0;
                for (uint32_t n = b0; n < b0 + HD_PEAK_BLOCK && n < t->samples; n++)
                    m = fmax(m, fabs((double)fw_sample(t, idx[k], n, c)));
                s += m;
            }
            peak = fmax(peak, s);
        }
    r.e_ref = e_ref;
    r.gain_energy = sqrt(e_ref / e_sum);
    r.gain_peak = 32767.0 / peak;
    r.gain = fmin(fmin(r.gain_energy, r.gain_peak), limit);
    return r;
}

/* Render K foci through the player into a whole-signal buffer (int32 samples
 * in S32 units or S16 units), `chs` device channels with the given map. */
static int32_t *render_all(const struct fw_table *t, struct hd_program *p, const uint32_t *idx, uint32_t K,
                           enum hd_sample_format fmt, unsigned chs, const unsigned *map, struct hd_mix *mix_out,
                           uint64_t *clipped)
{
    struct hd_board b;
    fw_board(&b, chs, fmt, 64);
    b.map_count = t->channels;
    memcpy(b.channel_map, map, t->channels * sizeof *map);
    struct hd_player pl;
    assert_int_equal(hd_player_init(&pl, &b), 0);
    struct hd_mix m = {.count = K};
    memcpy(m.index, idx, K * sizeof *idx);
    assert_int_equal(hd_mixer_gain(p, 1.0, b.gain_limit, &m), 0);
    hd_player_start_mix(&pl, p, &m);
    uint32_t periods = (t->samples + 63) / 64;
    int32_t *all = calloc((size_t)periods * 64 * chs, sizeof *all);
    int16_t *tmp16 = calloc((size_t)64 * chs, sizeof *tmp16);
    for (uint32_t q = 0; q < periods; q++) {
        if (fmt == HD_FMT_S32_LE) {
            hd_player_render(&pl, all + (size_t)q * 64 * chs, 64);
        } else {
            hd_player_render(&pl, tmp16, 64);
            for (uint32_t i = 0; i < 64 * chs; i++)
                all[(size_t)q * 64 * chs + i] = tmp16[i];
        }
    }
    assert_int_equal(hd_player_active(&pl), 0);
    *clipped = pl.stats.clipped_samples;
    *mix_out = m;
    free(tmp16);
    hd_player_free(&pl);
    return all;
}

static void check_against_reference(const struct fw_table *t, uint32_t K, enum hd_sample_format fmt, unsigned chs,
                                    const unsigned *map)
{
    struct hd_board b;
    fw_board(&b, chs, fmt, 64);
    b.map_count = t->channels;
    memcpy(b.channel_map, map, t->channels * sizeof *map);
    struct hd_program *p;
    char err[HD_ERR_MAX];
    assert_int_equal(hd_program_from_table(&t->table, &b, &p, err), 0);
    uint32_t idx[HD_MAX_VOICE_FOCI];
    for (uint32_t k = 0; k < K; k++)
        idx[k] = (k * 5 + 2) % t->foci; /* not in table order */
    struct ref r = ref_gain(t, idx, K, 1.0);
    struct hd_mix m;
    uint64_t clipped;
    int32_t *out = render_all(t, p, idx, K, fmt, chs, map, &m, &clipped);
    assert_true(fabs(m.gain_energy - r.gain_energy) <= 1e-12 * r.gain_energy);
    assert_true(fabs(m.gain_peak - r.gain_peak) <= 1e-12 * r.gain_peak);
    assert_true(fabs(m.gain - r.gain) <= 1e-12 * r.gain);
    const double unit = fmt == HD_FMT_S32_LE ? 65536.0 : 1.0;
    double e_out = 0.0;
    long exact = 0, total = 0;
    for (uint32_t n = 0; n < t->samples; n++) {
        unsigned mapped[HD_MAX_CHANNELS] = {0};
        for (uint32_t c = 0; c < t->channels; c++) {
            double s = 0.0;
            for (uint32_t k = 0; k < K; k++)
                s += fw_sample(t, idx[k], n, c);
            double y = r.gain * s * unit;
            double want = floor(y + 0.5);
            double got = out[(size_t)n * chs + map[c]];
            if (fabs(got - want) > 1.0)
                fail_msg("K=%u n=%u c=%u: got %.0f, reference %.3f", K, n, c, got, y);
            exact += got == want;
            total++;
            e_out += (got / unit) * (got / unit);
            mapped[map[c]] = 1;
        }
        for (unsigned ch = 0; ch < chs; ch++)
            if (!mapped[ch])
                assert_int_equal(out[(size_t)n * chs + ch], 0); /* unmapped channels stay silent */
    }
    assert_int_equal(clipped, 0);
    /* S16: only outputs within 1e-5 of a .5 boundary can differ. S32: the Q30
     * gain's quantization (<= |sum s| * 2^-15 LSB) may move any output by 1. */
    if (fmt == HD_FMT_S16_LE)
        assert_true(exact >= total - total / 1000);
    /* Energy: when the energy gain binds, the mix carries E_ref (up to output rounding). */
    if (r.gain == r.gain_energy)
        assert_true(fabs(e_out - r.e_ref) <= 1e-3 * r.e_ref);
    else
        assert_true(e_out < r.e_ref);
    free(out);
    hd_program_free(p);
}

static void reference_1_to_9_foci(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 9, N, FW_RANDOM, 3000, 7);
    const unsigned identity[C] = {0, 1, 2, 3, 4, 5, 6, 7};
    const unsigned scrambled[C] = {9, 7, 5, 3, 1, 0, 2, 4};
    for (uint32_t K = 1; K <= 9; K++) {
        check_against_reference(&t, K, HD_FMT_S16_LE, C, identity);
        check_against_reference(&t, K, HD_FMT_S32_LE, 10, scrambled);
    }
    fw_table_free(&t);
}

static void single_focus_is_exact(void **state)
{
    (void)state;
    /* One focus plays exactly as stored: g = 1 (truth: the table itself). */
    struct fw_table t;
    fw_table_make(&t, C, 2, N, FW_RANDOM, 32767, 3);
    struct hd_board b;
    fw_board(&b, C, HD_FMT_S32_LE, 64);
    struct hd_program *p;
    char err[HD_ERR_MAX];
    assert_int_equal(hd_program_from_table(&t.table, &b, &p, err), 0);
    const unsigned identity[C] = {0, 1, 2, 3, 4, 5, 6, 7};
    uint32_t idx = 1;
    struct hd_mix m;
    uint64_t clipped;
    int32_t *out = render_all(&t, p, &idx, 1, HD_FMT_S32_LE, C, identity, &m, &clipped);
    assert_true(m.gain == 1.0);
    for (uint32_t n = 0; n < N; n++)
        for (uint32_t c = 0; c < C; c++)
            assert_int_equal(out[n * C + c], fw_sample(&t, 1, n, c) * 65536);
    free(out);
    int32_t *out16 = render_all(&t, p, &idx, 1, HD_FMT_S16_LE, C, identity, &m, &clipped);
    for (uint32_t n = 0; n < N; n++)
        for (uint32_t c = 0; c < C; c++)
            assert_int_equal(out16[n * C + c], fw_sample(&t, 1, n, c));
    free(out16);
    hd_program_free(p);
    fw_table_free(&t);
}

static void uncorrelated_foci_fall_as_inverse_sqrt_k(void **state)
{
    (void)state;
    /* Disjoint supports: G[f][f'] = 0 and equal energies, so g = 1/sqrt(K)
     * exactly and each focus keeps 1/K of the energy. */
    struct fw_table t;
    fw_table_make(&t, C, 9, 900, FW_DISJOINT, 20000, 5);
    struct hd_board b;
    fw_board(&b, C, HD_FMT_S32_LE, 64);
    struct hd_program *p;
    char err[HD_ERR_MAX];
    assert_int_equal(hd_program_from_table(&t.table, &b, &p, err), 0);
    for (uint32_t K = 1; K <= 9; K++) {
        struct hd_mix m = {.count = K};
        for (uint32_t k = 0; k < K; k++)
            m.index[k] = k;
        assert_int_equal(hd_mixer_gain(p, 1.0, 1.0, &m), 0);
        assert_true(fabs(m.gain - 1.0 / sqrt((double)K)) < 1e-15);
        assert_true(m.gain == m.gain_energy);
    }
    hd_program_free(p);
    fw_table_free(&t);
}

static void correlated_foci_and_peak_limit(void **state)
{
    (void)state;
    struct hd_board b;
    fw_board(&b, C, HD_FMT_S16_LE, 64);
    struct hd_program *p;
    char err[HD_ERR_MAX];
    /* Identical foci: the sum is K s, energy K^2 E: g = 1/K, the mix equals one focus. */
    struct fw_table same;
    fw_table_make(&same, C, 4, 256, FW_CONSTANT, 30000, 1);
    assert_int_equal(hd_program_from_table(&same.table, &b, &p, err), 0);
    struct hd_mix m = {.count = 4, .index = {0, 1, 2, 3}};
    assert_int_equal(hd_mixer_gain(p, 1.0, 1.0, &m), 0);
    assert_true(fabs(m.gain - 0.25) < 1e-15);
    hd_program_free(p);
    fw_table_free(&same);
    /* Full-scale uncorrelated foci: the energy gain 1/sqrt(2) would clip, the
     * peak limit binds, nothing saturates, and the energy falls below E_ref. */
    struct fw_table loud;
    fw_table_make(&loud, C, 2, N, FW_RANDOM, 32767, 9);
    const unsigned identity[C] = {0, 1, 2, 3, 4, 5, 6, 7};
    assert_int_equal(hd_program_from_table(&loud.table, &b, &p, err), 0);
    uint32_t idx[2] = {0, 1};
    uint64_t clipped;
    int32_t *out = render_all(&loud, p, idx, 2, HD_FMT_S16_LE, C, identity, &m, &clipped);
    assert_true(m.gain_peak < m.gain_energy);
    assert_true(m.gain == m.gain_peak);
    assert_int_equal(clipped, 0);
    int32_t peak = 0;
    for (uint32_t i = 0; i < N * C; i++)
        peak = abs(out[i]) > peak ? abs(out[i]) : peak;
    assert_true(peak <= 32767);
    assert_true(peak > 20000); /* the bound is not absurdly loose */
    free(out);
    /* The board's gain_limit caps g too. */
    m = (struct hd_mix){.count = 1, .index = {0}};
    assert_int_equal(hd_mixer_gain(p, 1.0, 0.25, &m), 0);
    assert_true(m.gain == 0.25);
    m.count = 0;
    assert_int_equal(hd_mixer_gain(p, 1.0, 1.0, &m), -EINVAL);
    m = (struct hd_mix){.count = 1, .index = {2}};
    assert_int_equal(hd_mixer_gain(p, 1.0, 1.0, &m), -EINVAL);
    hd_program_free(p);
    fw_table_free(&loud);
}

static void conversion_rounding_and_saturation(void **state)
{
    (void)state;
    const int64_t one = (int64_t)1 << 30;
    /* Hand-computed: round half up, saturate instead of wrapping. */
    const int64_t acc[] = {0,           one / 2,      -one / 2,     one + one / 2 - 1, -(one + one / 2), 32767 * one,
                           32768 * one, -32768 * one, -32769 * one, INT64_MAX / 4,     -(INT64_MAX / 4)};
    const int16_t want16[] = {0, 1, 0, 1, -1, 32767, 32767, -32768, -32768, 32767, -32768};
    int16_t out16[11];
    assert_int_equal(haptic_mix_to_s16(acc, out16, 11), 4);
    for (int i = 0; i < 11; i++)
        assert_int_equal(out16[i], want16[i]);
    const int64_t u = (int64_t)1 << 14; /* one S32 LSB */
    const int64_t acc32[] = {u / 2,
                             -u / 2,
                             (int64_t)INT32_MAX * u,
                             ((int64_t)INT32_MAX + 1) * u,
                             (int64_t)INT32_MIN * u,
                             ((int64_t)INT32_MIN - 1) * u};
    const int32_t want32[] = {1, 0, INT32_MAX, INT32_MAX, INT32_MIN, INT32_MIN};
    int32_t out32[6];
    assert_int_equal(haptic_mix_to_s32(acc32, out32, 6), 2);
    for (int i = 0; i < 6; i++)
        assert_int_equal(out32[i], want32[i]);
}

static void overlapping_voices_saturate(void **state)
{
    (void)state;
    /* ADD policy: two full-scale voices overlap; the sum saturates, never wraps. */
    for (int fmt = HD_FMT_S16_LE; fmt <= HD_FMT_S32_LE; fmt++) {
        for (int sign = -1; sign <= 1; sign += 2) {
            struct fw_table t;
            fw_table_make(&t, C, 1, 128, FW_CONSTANT, sign * 30000, 1);
            struct hd_board b;
            fw_board(&b, C, (enum hd_sample_format)fmt, 64);
            struct hd_program *p;
            char err[HD_ERR_MAX];
            assert_int_equal(hd_program_from_table(&t.table, &b, &p, err), 0);
            struct hd_player pl;
            assert_int_equal(hd_player_init(&pl, &b), 0);
            uint32_t id = t.ids[0];
            assert_int_equal(hd_player_start(&pl, p, &id, 1), 1);
            assert_int_equal(hd_player_start(&pl, p, &id, 1), 1);
            int32_t out[64 * C];
            hd_player_render(&pl, out, 64);
            for (uint32_t i = 0; i < 64 * C; i++) {
                if (fmt == HD_FMT_S16_LE)
                    assert_int_equal(((int16_t *)out)[i], sign > 0 ? INT16_MAX : INT16_MIN);
                else
                    assert_int_equal(out[i], sign > 0 ? INT32_MAX : INT32_MIN);
            }
            assert_int_equal(pl.stats.clipped_samples, 64 * C);
            hd_player_free(&pl);
            hd_program_free(p);
            fw_table_free(&t);
        }
    }
}

static void program_checks_board(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, C, 2, 100, FW_RANDOM, 100, 1);
    char file[] = "/tmp/hapticd-program-XXXXXX";
    int fd = mkstemp(file);
    assert_true(fd >= 0);
    close(fd);
    fw_table_write(&t, file);
    struct hd_board b;
    struct hd_program *p = NULL;
    char err[HD_ERR_MAX] = "";
    fw_board(&b, C, HD_FMT_S32_LE, 64);
    b.rate_hz = 44100;
    assert_int_equal(hd_program_load(file, &b, &p, err), -EINVAL);
    assert_non_null(strstr(err, file));
    assert_non_null(strstr(err, "rate_hz"));
    assert_non_null(strstr(err, b.path));
    fw_board(&b, C, HD_FMT_S32_LE, 64);
    b.map_count = 6;
    assert_int_equal(hd_program_load(file, &b, &p, err), -EINVAL);
    assert_non_null(strstr(err, "channel_map"));
    assert_null(strchr(err, '\n'));
    fw_board(&b, C, HD_FMT_S32_LE, 64);
    assert_int_equal(hd_program_load(file, &b, &p, err), 0);
    /* ids 1000, 990 in table order; lookups by id, unknown ids -1 */
    assert_int_equal(hd_program_find(p, 1000), 0);
    assert_int_equal(hd_program_find(p, 990), 1);
    assert_int_equal(hd_program_find(p, 995), -1);
    assert_int_equal(hd_program_find(p, 0), -1);
    assert_int_equal(hd_program_find(p, UINT32_MAX), -1);
    hd_program_free(p);
    unlink(file);
    assert_int_equal(hd_program_load(file, &b, &p, err), -EINVAL);
    assert_non_null(strstr(err, file));
    fw_table_free(&t);
}

/* The latency hapticd states is the slowest focus's lead time, read from the
 * table's playback section; a table without one (format 1.0) says nothing. */
static void program_lead_time_is_the_largest_focus_lead(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, 8, 3, 480, FW_RANDOM, 1000, 11);
    struct hd_board b;
    fw_board(&b, 8, HD_FMT_S32_LE, 64);
    struct hd_program *p;
    char err[HD_ERR_MAX];
    assert_int_equal(hd_program_from_table(&t.table, &b, &p, err), 0);
    assert_true(isnan(hd_program_lead_time_s(p)));
    hd_program_free(p);

    const double lead_s[3] = {0.0572, 0.0601, 0.0125};
    fw_table_encode(&t, lead_s);
    assert_int_equal(hd_program_from_table(&t.table, &b, &p, err), 0);
    assert_true(hd_program_lead_time_s(p) == 0.0601);
    hd_program_free(p);
    fw_table_free(&t);
}

/* Two foci of two channels, each 2000 on both channels in its own third of
 * frames 0..383 (blocks 0-5: one focus per block, so P = 2000 there), and
 * 30000 on channel 1 in one frame of both: the only loud samples, summing to
 * 60000, lie in one peak block: the final one (partial at N = 394: 10
 * frames; full at N = 448) or the first. The energy gain, sqrt(E_ref / E_sum)
 * = sqrt(2.436e9 / 6.672e9) = 0.604, would play that frame at 36,250, so the
 * peak limit 32767 / 60000 must bind; then it plays at exactly 32767. */
static void a_mix_loud_only_in_its_last_or_first_peak_block_is_limited(void **state)
{
    (void)state;
    const struct {
        uint32_t frames, loud;
    } cases[] = {{394, 393}, {448, 447}, {394, 0}};
    for (int i = 0; i < 3; i++) {
        const uint32_t n_frames = cases[i].frames, loud = cases[i].loud;
        struct fw_table t;
        fw_table_make(&t, 2, 2, n_frames, FW_CONSTANT, 1, 1);
        for (uint32_t f = 0; f < 2; f++)
            for (uint32_t n = 0; n < n_frames; n++)
                for (uint32_t c = 0; c < 2; c++) {
                    int16_t v = n < 384 && n / 192 == f ? 2000 : 0;
                    if (n == loud && c == 1)
                        v = 30000;
                    t.samples_buf[((size_t)f * n_frames + n) * 2 + c] = v;
                }
        fw_table_encode(&t, NULL);
        struct hd_board b;
        fw_board(&b, 2, HD_FMT_S16_LE, 64);
        struct hd_program *p;
        char err[HD_ERR_MAX];
        assert_int_equal(hd_program_from_table(&t.table, &b, &p, err), 0);
        assert_int_equal(p->blocks, 7);
        const uint32_t idx[2] = {0, 1};
        struct ref r = ref_gain(&t, idx, 2, 1.0);
        assert_true(r.gain_peak == 32767.0 / 60000.0 && r.gain_energy > 0.6);
        const unsigned identity[2] = {0, 1};
        struct hd_mix m;
        uint64_t clipped;
        int32_t *out = render_all(&t, p, idx, 2, HD_FMT_S16_LE, 2, identity, &m, &clipped);
        if (m.gain_peak != 32767.0 / 60000.0 || m.gain != m.gain_peak)
            fail_msg("N=%u, loud frame %u: gain_peak %.9g (want 32767/60000), gain %.9g, gain_energy %.9g", n_frames,
                     loud, m.gain_peak, m.gain, m.gain_energy);
        assert_true(fabs(m.gain_energy - r.gain_energy) <= 1e-12 * r.gain_energy);
        assert_int_equal(clipped, 0);
        assert_int_equal(out[(size_t)loud * 2 + 1], 32767);
        free(out);
        hd_program_free(p);
        fw_table_free(&t);
    }
}

/* A voice holds up to HD_MAX_VOICE_FOCI foci: exactly that many are mixed
 * (with the same energy gain as the reference over all of them), one more
 * is refused; through the player, a 33rd id is dropped, not the voice. */
static void a_voice_takes_exactly_hd_max_voice_foci(void **state)
{
    (void)state;
    struct fw_table t;
    fw_table_make(&t, 2, HD_MAX_VOICE_FOCI + 1, 64, FW_RANDOM, 1000, 13);
    struct hd_board b;
    fw_board(&b, 2, HD_FMT_S16_LE, 64);
    struct hd_program *p;
    char err[HD_ERR_MAX];
    assert_int_equal(hd_program_from_table(&t.table, &b, &p, err), 0);
    struct {
        struct hd_mix m;
        uint32_t after[4]; /* zero: an index read past the array would be a valid one */
    } z;
    memset(&z, 0, sizeof z);
    uint32_t idx[HD_MAX_VOICE_FOCI];
    for (uint32_t k = 0; k < HD_MAX_VOICE_FOCI; k++)
        idx[k] = z.m.index[k] = HD_MAX_VOICE_FOCI - k; /* foci 32..1 */
    z.m.count = HD_MAX_VOICE_FOCI;
    assert_int_equal(hd_mixer_gain(p, 1.0, 1.0, &z.m), 0);
    struct ref r = ref_gain(&t, idx, HD_MAX_VOICE_FOCI, 1.0);
    assert_true(fabs(z.m.gain_energy - r.gain_energy) <= 1e-12 * r.gain_energy);
    assert_true(fabs(z.m.gain - r.gain) <= 1e-12 * r.gain);
    z.m.count = HD_MAX_VOICE_FOCI + 1;
    assert_int_equal(hd_mixer_gain(p, 1.0, 1.0, &z.m), -EINVAL);

    struct hd_player pl;
    b.max_foci = HD_MAX_VOICE_FOCI; /* the board lets a voice have them all */
    assert_int_equal(hd_player_init(&pl, &b), 0);
    uint32_t ids[HD_MAX_VOICE_FOCI + 1];
    for (uint32_t k = 0; k <= HD_MAX_VOICE_FOCI; k++)
        ids[k] = t.ids[k];
    assert_int_equal(hd_player_start(&pl, p, ids, HD_MAX_VOICE_FOCI), 1);
    assert_int_equal(pl.stats.dropped_foci, 0);
    assert_int_equal(hd_player_start(&pl, p, ids, HD_MAX_VOICE_FOCI + 1), 1);
    assert_int_equal(pl.stats.dropped_foci, 1);
    unsigned full = 0;
    for (unsigned v = 0; v < HD_MAX_VOICES; v++)
        full += pl.voices[v].program != NULL && pl.voices[v].mix.count == HD_MAX_VOICE_FOCI;
    assert_int_equal(full, 2);
    hd_player_free(&pl);
    hd_program_free(p);
    fw_table_free(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(reference_1_to_9_foci),
        cmocka_unit_test(single_focus_is_exact),
        cmocka_unit_test(uncorrelated_foci_fall_as_inverse_sqrt_k),
        cmocka_unit_test(correlated_foci_and_peak_limit),
        cmocka_unit_test(conversion_rounding_and_saturation),
        cmocka_unit_test(overlapping_voices_saturate),
        cmocka_unit_test(program_checks_board),
        cmocka_unit_test(program_lead_time_is_the_largest_focus_lead),
        cmocka_unit_test(a_mix_loud_only_in_its_last_or_first_peak_block_is_limited),
        cmocka_unit_test(a_voice_takes_exactly_hd_max_voice_foci),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
