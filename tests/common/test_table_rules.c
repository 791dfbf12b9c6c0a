/* The rules of docs/table-format.md that a reader written from the document
 * alone must apply exactly as common/ does, each with a hand-computed vector:
 * the Gram matrix against the payload, reserved bytes and gaps, provenance
 * text, focus ids, the sample -32768, the 1.1 playback, 1.2 panel and 1.3
 * range sections, a 1.0 table, and the order in which faults are reported. Tables are edited at the
 * documented offsets and the CRC re-made, so the content check must refuse. */
#define _POSIX_C_SOURCE 200809L /* fmemopen */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "table_fixture.h"

static uint32_t le32(const uint8_t *p) { return p[0] | p[1] << 8 | p[2] << 16 | (uint32_t)p[3] << 24; }
static uint64_t le64(const uint8_t *p) { return le32(p) | (uint64_t)le32(p + 4) << 32; }
static void put(uint8_t *p, size_t width, uint64_t v)
{
    for (size_t i = 0; i < width; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}
static void put_f64(uint8_t *p, double d)
{
    uint64_t u;
    memcpy(&u, &d, 8);
    put(p, 8, u);
}
static double get_f64(const uint8_t *p)
{
    uint64_t u = le64(p);
    double d;
    memcpy(&d, &u, 8);
    return d;
}

/* Validate a private, exactly-sized copy (ASan sees any overread). */
static int check(const uint8_t *b, size_t size, haptic_table_error *err)
{
    uint8_t *copy = malloc(size);
    memcpy(copy, b, size);
    haptic_table t;
    int rc = haptic_table_validate(copy, size, &t, err);
    free(copy);
    return rc;
}

/* Edit, re-make the CRC, and expect `want` with `needle` in the message and
 * the error's offset at `at` (if at != UINT64_MAX). */
static void expect(uint8_t *b, size_t size, int want, const char *needle, uint64_t at, const char *what)
{
    table_fixture_fix_crc(b, size);
    haptic_table_error err;
    int rc = check(b, size, &err);
    if (rc != want || (needle && !strstr(err.message, needle)) || (at != UINT64_MAX && err.offset != at))
        fail_msg("%s: rc %d at %llu (%s), want %d with '%s' at %llu", what, rc, (unsigned long long)err.offset,
                 err.message, want, needle ? needle : "", (unsigned long long)at);
}

/* One channel, two foci of two frames: s0 = (3, 4), s1 = (-32768, 1).
 * By hand: E0 = 9 + 16 = 25; E1 = 2^30 + 1 = 1073741825;
 * G01 = 3 (-32768) + 4 = -98300. */
static size_t tiny_table(uint8_t **out)
{
    static int16_t s[] = {3, 4, -32768, 1};
    static const double cxy[] = {0.0, 0.0}, fxy[] = {0.1, 0.1, 0.2, 0.2}, scale[] = {1e-5, 1e-5}, lead[] = {0, 0};
    static const uint32_t ids[] = {1, 2};
    haptic_table_spec spec = {
        1000, 1, 2, 2, cxy, ids, fxy, scale, s, NULL, NULL, NULL, NULL, HAPTIC_DRIVE_FORCE, 1.0, lead, NULL, NULL};
    size_t size = (size_t)haptic_table_encoded_size(&spec);
    *out = malloc(size);
    haptic_table_error err;
    if (haptic_table_encode(&spec, *out, size, &err) != 0)
        fail_msg("%s", err.message);
    return size;
}

static void gram_and_energies_are_the_exact_sums(void **state)
{
    (void)state;
    uint8_t *b;
    size_t size = tiny_table(&b);
    uint64_t fo = le64(b + 56), gr = le64(b + 64);
    assert_true(get_f64(b + gr) == 25.0);
    assert_true(get_f64(b + gr + 8) == -98300.0 && get_f64(b + gr + 16) == -98300.0);
    assert_true(get_f64(b + gr + 24) == 1073741825.0);
    assert_true(get_f64(b + fo + 32) == 25.0 && get_f64(b + fo + 48 + 32) == 1073741825.0);
    assert_int_equal(check(b, size, NULL), 0); /* -32768 is an allowed sample */
    free(b);
}

static void an_altered_gram_or_payload_under_a_fresh_crc_is_refused(void **state)
{
    (void)state;
    uint8_t *b, *w;
    size_t size = tiny_table(&b);
    w = malloc(size);
    uint64_t fo = le64(b + 56), gr = le64(b + 64), pl = le64(b + 80);
    /* Off-diagonal off by one, symmetric and within Cauchy-Schwarz
     * (|G01| <= sqrt(25 * 1073741825) = 163840.0000076): only the payload says. */
    memcpy(w, b, size);
    put_f64(w + gr + 8, -98301.0);
    put_f64(w + gr + 16, -98301.0);
    expect(w, size, HAPTIC_TABLE_EGRAM, "gram[1][0]", gr + 16, "gram[1][0] altered");
    /* Diagonal and energy altered together (they still agree with each other). */
    memcpy(w, b, size);
    put_f64(w + gr + 24, 1073741826.0);
    put_f64(w + fo + 48 + 32, 1073741826.0);
    expect(w, size, HAPTIC_TABLE_EGRAM, "gram[1][1]", gr + 24, "gram[1][1] altered");
    /* Payload: s1[1] 1 -> 2 changes E1 (named on the diagonal first). */
    memcpy(w, b, size);
    put(w + pl + 6, 2, 2);
    expect(w, size, HAPTIC_TABLE_EGRAM, "gram[1][1]", gr + 24, "payload, energy changed");
    /* Payload: s1[1] 1 -> -1 keeps E1 but G01 becomes -98308. */
    memcpy(w, b, size);
    put(w + pl + 6, 2, (uint16_t)-1);
    expect(w, size, HAPTIC_TABLE_EGRAM, "-98308", gr + 16, "payload, energy kept");
    free(w);
    free(b);
}

/* 4 channels x 2,100,000 frames, every sample 32767 but the last (2):
 * E = 8,399,999 * 32767^2 + 4 = 9,018,879,753,923,715, above 2^53 where
 * binary64 steps by 2: a tie between ...714 (significand ...857, odd) and
 * ...716 (significand ...858, even); round-to-nearest-even stores ...716. */
static void energy_above_2_pow_53_is_the_exact_sum_rounded_once(void **state)
{
    (void)state;
    const uint32_t n = 2100000;
    const uint16_t c = 4;
    int16_t *s = malloc(sizeof *s * n * c);
    for (size_t i = 0; i < (size_t)n * c; i++)
        s[i] = 32767;
    s[(size_t)n * c - 1] = 2;
    const double cxy[8] = {0}, fxy[2] = {0.1, 0.1}, scale[1] = {1e-5};
    const uint32_t ids[1] = {7};
    haptic_table_spec spec = {48000, c, 1, n, cxy, ids, fxy, scale, s, NULL, NULL, NULL, NULL, 0, 0, NULL, NULL, NULL};
    size_t size = (size_t)haptic_table_encoded_size(&spec);
    uint8_t *b = malloc(size);
    assert_int_equal(haptic_table_encode(&spec, b, size, NULL), 0);
    assert_true(8399999ull * 1073676289ull + 4ull == 9018879753923715ull);
    assert_true((uint64_t)get_f64(b + le64(b + 64)) == 9018879753923716ull);
    assert_int_equal(check(b, size, NULL), 0);
    free(b);
    free(s);
}

/* K foci of one channel x n frames, every signal the same ramp, built at the
 * documented offsets (1.1 without a playback section): every Gram element is
 * E. Used on both sides of the off-diagonal cost bound. */
static size_t same_signal_table(uint32_t k, uint32_t n, uint8_t **out, uint64_t *gram_off)
{
    const uint64_t fo = 128 + 16, gr = fo + 48ull * k, pr = gr + 8ull * k * k;
    const uint64_t pl = (pr + 256 + 63) / 64 * 64, size = pl + 2ull * k * n + 4;
    uint8_t *b = calloc(1, size);
    memcpy(b, "HAPTBL\r\n", 8);
    put(b + 8, 2, 1);
    put(b + 10, 2, 1);
    put(b + 12, 4, 128);
    put(b + 20, 4, 1000);
    put(b + 24, 2, 1);
    put(b + 26, 2, 1);
    put(b + 28, 4, k);
    put(b + 32, 4, n);
    put(b + 40, 8, size);
    put(b + 48, 8, 128);
    put(b + 56, 8, fo);
    put(b + 64, 8, gr);
    put(b + 72, 8, pr);
    put(b + 80, 8, pl);
    put(b + 88, 8, 2ull * k * n);
    double e = 0;
    for (uint32_t i = 0; i < n; i++) {
        int16_t v = (int16_t)(i % 200 - 100);
        e += (double)v * v;
        for (uint32_t f = 0; f < k; f++)
            put(b + pl + 2 * ((uint64_t)f * n + i), 2, (uint16_t)v);
    }
    for (uint32_t f = 0; f < k; f++) {
        uint8_t *r = b + fo + 48ull * f;
        put(r, 4, f);
        put_f64(r + 8, 0.1);
        put_f64(r + 16, 0.1);
        put_f64(r + 24, 1e-5);
        put_f64(r + 32, e);
    }
    for (uint64_t i = 0; i < (uint64_t)k * k; i++)
        put_f64(b + gr + 8 * i, e);
    table_fixture_fix_crc(b, size);
    *out = b;
    *gram_off = gr;
    return size;
}

static void off_diagonal_check_follows_the_documented_cost_bound(void **state)
{
    (void)state;
    /* 1024 foci: 523776 pairs. 8200 frames: 4,294,963,200 products <= 2^32,
     * checked; 8201 frames: 4,295,486,976 > 2^32, diagonal only. */
    const uint32_t frames[2] = {8200, 8201};
    for (int k = 0; k < 2; k++) {
        uint8_t *b;
        uint64_t gr;
        size_t size = same_signal_table(1024, frames[k], &b, &gr);
        if (k == 1) /* (within the bound, accepting the intact table costs all 4.3e9 products) */
            assert_int_equal(check(b, size, NULL), 0);
        double e = get_f64(b + gr);
        put_f64(b + gr + 8, e - 1);        /* gram[0][1] */
        put_f64(b + gr + 1024 * 8, e - 1); /* gram[1][0] */
        table_fixture_fix_crc(b, size);
        haptic_table_error err;
        int rc = check(b, size, &err);
        if (k == 0 && (rc != HAPTIC_TABLE_EGRAM || !strstr(err.message, "gram[1][0]")))
            fail_msg("within the bound: rc %d (%s)", rc, err.message);
        if (k == 1 && rc != 0)
            fail_msg("above the bound the off-diagonal is not compared with the payload: rc %d (%s)", rc, err.message);
        free(b);
    }
}

/* Cauchy-Schwarz exactly as documented, fabs(g_ij) <= sqrt(g_ii g_jj) (1.0 + 1e-9),
 * on a table above the off-diagonal cost bound, where the structure check is
 * all that holds the off-diagonal: every element of same_signal_table is E,
 * so the bound is E (1 + 1e-9) in binary64; the bound itself is accepted, the
 * next double above it (and a violation of 1e-6) refused, at gram[1][0]. */
static void cauchy_schwarz_slack_is_1e_9_above_the_cost_bound(void **state)
{
    (void)state;
    uint8_t *b, *w;
    uint64_t gr;
    size_t size = same_signal_table(1024, 8201, &b, &gr);
    w = malloc(size);
    const double e = get_f64(b + gr);
    const double bound = sqrt(e * e) * (1.0 + 1e-9);
    assert_true(e == 27344700.0 && bound > e); /* 41 x 666700 + 100^2; the bound a true violation */
    struct {
        double g;
        int want;
    } cases[] = {
        {bound, 0},
        {-bound, 0},
        {nextafter(bound, INFINITY), HAPTIC_TABLE_EGRAM},
        {-nextafter(bound, INFINITY), HAPTIC_TABLE_EGRAM},
        {e * (1.0 + 1e-6), HAPTIC_TABLE_EGRAM},
        {e * (1.0 + 1e-4), HAPTIC_TABLE_EGRAM},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        memcpy(w, b, size);
        put_f64(w + gr + 8, cases[i].g);        /* gram[0][1] */
        put_f64(w + gr + 1024 * 8, cases[i].g); /* gram[1][0] */
        char what[40];
        snprintf(what, sizeof what, "Cauchy-Schwarz case %zu", i);
        expect(w, size, cases[i].want, cases[i].want ? "violates Cauchy-Schwarz" : NULL,
               cases[i].want ? gr + 1024 * 8 : UINT64_MAX, what);
    }
    free(w);
    free(b);
}

/* Within the bound a Cauchy-Schwarz violation is named by the structure
 * check (step 11), before the payload comparison (step 13) could say it:
 * |G01| <= sqrt(25 * 1073741825) (1 + 1e-9) = 163840.000171 in tiny_table. */
static void cauchy_schwarz_is_named_before_the_payload_comparison(void **state)
{
    (void)state;
    uint8_t *b;
    size_t size = tiny_table(&b);
    uint64_t gr = le64(b + 64);
    put_f64(b + gr + 8, -163840.5);
    put_f64(b + gr + 16, -163840.5);
    expect(b, size, HAPTIC_TABLE_EGRAM, "violates Cauchy-Schwarz", gr + 16, "|G01| 163840.5");
    put_f64(b + gr + 8, -163840.0); /* within: then the payload says */
    put_f64(b + gr + 16, -163840.0);
    expect(b, size, HAPTIC_TABLE_EGRAM, "the payload gives -98300", gr + 16, "|G01| 163840");
    /* An infinite element is refused as not finite even where the bound is
     * infinite too: diagonals (and energies) of 1e200 make sqrt(g00 g11)
     * overflow; the payload would name gram[0][0] only later. */
    const uint64_t fo = le64(b + 56);
    put_f64(b + gr, 1e200);
    put_f64(b + fo + 32, 1e200);
    put_f64(b + gr + 24, 1e200);
    put_f64(b + fo + 48 + 32, 1e200);
    put_f64(b + gr + 8, INFINITY);
    put_f64(b + gr + 16, INFINITY);
    expect(b, size, HAPTIC_TABLE_EGRAM, "gram[1][0]", gr + 16, "G01 infinite, bound infinite");
    put_f64(b + gr + 8, 1e300); /* finite: held by the bound (inf) alone, so the payload names the diagonal */
    put_f64(b + gr + 16, 1e300);
    expect(b, size, HAPTIC_TABLE_EGRAM, "gram[0][0]", gr, "G01 1e300, bound infinite");
    free(b);
}

static void focus_ids_0_and_ffffffff_are_ordinary_and_repeats_are_named(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 2, 3, 8, 5);
    fx.ids[0] = 0;
    fx.ids[1] = 0xFFFFFFFFu;
    uint8_t *b;
    size_t size = table_fixture_encode(&fx, &b);
    assert_true(size > 0);
    haptic_table t;
    assert_int_equal(haptic_table_validate(b, size, &t, NULL), 0);
    assert_int_equal(haptic_table_find_focus(&t, 0), 0);
    assert_int_equal(haptic_table_find_focus(&t, 0xFFFFFFFFu), 1);
    uint64_t fo = le64(b + 56);
    put(b + fo + 2 * 48, 4, 0xFFFFFFFFu); /* focus 2 repeats focus 1 */
    expect(b, size, HAPTIC_TABLE_EFIELD, "focus 2 id): 4294967295 repeats focus 1", fo + 2 * 48, "repeat");
    free(b);
    table_fixture_free(&fx);
}

static void reserved_bytes_and_gaps_are_zero_up_to_the_known_minor(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 2, 3, 8, 3); /* playback at 632..672, payload at 704 */
    fx.spec.panel = NULL;
    uint8_t *b, *w;
    size_t size = table_fixture_encode(&fx, &b);
    w = malloc(size);
    uint64_t pb = le64(b + 96), pl = le64(b + 80), gap = pb + 16 + 3 * 8;
    assert_int_equal(pb, 632);
    assert_int_equal(pl, 704);
    /* 104..111 and 112..119: the absent panel and range sections' offsets. */
    struct {
        uint64_t at;
        uint8_t v;
        const char *needle;
    } edits[] = {
        {gap, 1, "gap between sections"}, {pl - 1, 0x80, "gap between sections"}, {104, 1, "header reserved"},
        {112, 1, "header reserved"},      {119, 0x80, "header reserved"},         {120, 1, "header reserved"},
        {127, 1, "header reserved"},
    };
    for (size_t i = 0; i < sizeof edits / sizeof *edits; i++) {
        memcpy(w, b, size);
        w[edits[i].at] = edits[i].v;
        expect(w, size, HAPTIC_TABLE_EFIELD, edits[i].needle, edits[i].at, edits[i].needle);
        put(w + 10, 2, 4); /* the same bytes in a 1.4 file: a later minor may use them */
        expect(w, size, 0, NULL, UINT64_MAX, "minor 4");
    }
    /* An optional flag 1.3 does not define: refused in 1.3, ignored in 1.4. */
    memcpy(w, b, size);
    put(w + 16, 4, 0x80010000u);
    expect(w, size, HAPTIC_TABLE_EFIELD, "optional bits 0x80000000 unknown in version 1.3", 16, "flag 31");
    put(w + 10, 2, 4);
    expect(w, size, 0, NULL, UINT64_MAX, "flag 31 in 1.4");
    free(w);
    free(b);
    table_fixture_free(&fx);
}

static void provenance_text_is_checked_as_documented(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 1, 1, 4, 9);
    uint8_t *b, *w;
    size_t size = table_fixture_encode(&fx, &b);
    w = malloc(size);
    const uint64_t pr = le64(b + 72);
    /* field offset, text (NUL-padded to 64), 0 = accepted or the offending byte's index in the field. */
    struct {
        unsigned field;
        const char *text;
        size_t n;
        long bad;
        const char *needle;
    } cases[] = {
        {0, "", 0, -1, NULL}, /* empty: not known */
        {0, "Glasplatte \xc3\xbc \xe2\x82\xac \xf0\x9f\x91\x86", 22, -1, NULL},
        {0, "a\xc3(", 3, 1, "not valid UTF-8"},             /* lead byte without continuation */
        {0, "\xc0\xaf", 2, 0, "not valid UTF-8"},           /* overlong '/' */
        {0, "\xed\xa0\x80", 3, 0, "not valid UTF-8"},       /* surrogate U+D800 */
        {0, "\xf4\x90\x80\x80", 4, 0, "not valid UTF-8"},   /* U+110000 */
        {0, "x\xc2\x85", 3, 1, "control character U+0085"}, /* C1 NEL */
        {0, "x\x1b[31m", 6, 1, "control character U+001B"}, /* an escape sequence */
        {128, "calibgen 0.1.0", 14, -1, NULL},
        {64, "crc32:0badf00d", 14, -1, NULL},
        {64, "sha-1:00", 8, -1, NULL},
        {64, "CRC32:0badf00d", 14, 0, "algorithm:hex"},
        {64, "crc32:0BADF00D", 14, 7, "algorithm:hex"},
        {64, "crc32:abc", 9, 8, "algorithm:hex"}, /* not a whole number of bytes */
        {64, "crc32:", 6, 5, "algorithm:hex"},
        {64, "crc32", 5, 5, "algorithm:hex"},
        {64, ":00", 3, 0, "algorithm:hex"},
        {64, "1crc:00", 7, 0, "algorithm:hex"},
        {192, "2026-11-21T23:59:60Z", 20, -1, NULL},
        {192, "2026-13-01T00:00:00Z", 20, 5, "YYYY-MM-DDTHH:MM:SSZ"},
        {192, "2026-11-00T00:00:00Z", 20, 8, "YYYY-MM-DDTHH:MM:SSZ"},
        {192, "2026-11-21 00:00:00Z", 20, 10, "YYYY-MM-DDTHH:MM:SSZ"},
        {192, "2026-11-21T24:00:00Z", 20, 11, "YYYY-MM-DDTHH:MM:SSZ"},
        {192, "2026-11-21T00:00:00", 19, 19, "YYYY-MM-DDTHH:MM:SSZ"},
        {192, "2026-11-21T00:00:00Z+", 21, 20, "YYYY-MM-DDTHH:MM:SSZ"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        memcpy(w, b, size);
        memset(w + pr + cases[i].field, 0, 64);
        memcpy(w + pr + cases[i].field, cases[i].text, cases[i].n);
        char what[32];
        snprintf(what, sizeof what, "provenance case %zu", i);
        if (cases[i].bad < 0)
            expect(w, size, 0, NULL, UINT64_MAX, what);
        else
            expect(w, size, HAPTIC_TABLE_EFIELD, cases[i].needle, pr + cases[i].field + (uint64_t)cases[i].bad, what);
    }
    /* A sequence cut by the end of the 64-byte field. */
    memcpy(w, b, size);
    memset(w + pr, 'a', 63);
    w[pr + 63] = 0xc3;
    expect(w, size, HAPTIC_TABLE_EFIELD, "not valid UTF-8", pr + 63, "cut sequence");
    free(w);
    free(b);
    table_fixture_free(&fx);
}

static void playback_section_is_checked_as_documented(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 2, 2, 480, 4); /* 480 frames at 48 kHz: lead times up to 0.01 + 1 s */
    fx.spec.panel = NULL;                  /* (panel_section_is_checked_as_documented) */
    uint8_t *b, *w;
    size_t size = table_fixture_encode(&fx, &b);
    w = malloc(size);
    const uint64_t pb = le64(b + 96);
    haptic_table t;
    assert_int_equal(haptic_table_validate(b, size, &t, NULL), 0);
    assert_true(haptic_table_force_full_scale_n(&t) == 2.5);
    assert_int_equal(haptic_table_drive_kind(&t), HAPTIC_DRIVE_EXCITER);
    haptic_focus_info fi;
    assert_int_equal(haptic_table_focus(&t, 1, &fi), 0);
    assert_true(fi.lead_time_s == 0.005 && haptic_table_lead_time_s(&t, 1) == 0.005);
    assert_true(isnan(haptic_table_lead_time_s(&t, 2)));

    const double last = 480.0 / 48000.0 + 1.0; /* N / rate + 1 s, in binary64 */
    struct {
        uint64_t at;
        int width;
        double f;
        uint64_t u;
        int ok;
    } cases[] = {
        {pb + 0, 8, 1e6, 0, 1},
        {pb + 0, 8, nextafter(1e6, 2e6), 0, 0},
        {pb + 0, 8, 0.0, 0, 0},
        {pb + 0, 8, NAN, 0, 0},
        {pb + 0, 8, -2.5, 0, 0},
        {pb + 8, 2, 0, 1, 1},
        {pb + 8, 2, 0, 3, 1},
        {pb + 8, 2, 0, 0, 0},
        {pb + 8, 2, 0, 4, 0},
        {pb + 10, 2, 0, 1, 0},
        {pb + 12, 4, 0, 1, 0},
        {pb + 16, 8, 0.0, 0, 1},
        {pb + 16, 8, -0.0, 0, 1},
        {pb + 24, 8, last, 0, 1},
        {pb + 24, 8, nextafter(last, 2.0), 0, 0},
        {pb + 16, 8, -1e-300, 0, 0},
        {pb + 24, 8, INFINITY, 0, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        memcpy(w, b, size);
        if (cases[i].width == 8)
            put_f64(w + cases[i].at, cases[i].f);
        else
            put(w + cases[i].at, (size_t)cases[i].width, cases[i].u);
        char what[32];
        snprintf(what, sizeof what, "playback case %zu", i);
        expect(w, size, cases[i].ok ? 0 : HAPTIC_TABLE_EFIELD, NULL, cases[i].ok ? UINT64_MAX : cases[i].at, what);
    }
    /* The section must not overlap the provenance or the payload. */
    memcpy(w, b, size);
    put(w + 96, 8, pb - 8);
    expect(w, size, HAPTIC_TABLE_ELAYOUT, "playback_offset", 96, "overlaps provenance");
    /* Flag cleared: the offset field is then reserved and must be 0. */
    memcpy(w, b, size);
    put(w + 16, 4, 0);
    expect(w, size, HAPTIC_TABLE_EFIELD, "header reserved", 96, "offset without flag");
    put(w + 96, 8, 0); /* section bytes are then a gap: 2.5 N = 0x4004000000000000 */
    expect(w, size, HAPTIC_TABLE_EFIELD, "gap between sections", pb + 6, "section without flag");
    free(w);
    free(b);
    table_fixture_free(&fx);
}

/* 1.2's panel section: its ranges at their edges, its reserved bytes, its
 * place after the playback section, its offset without its flag. */
static void panel_section_is_checked_as_documented(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 2, 2, 48, 4);
    uint8_t *b, *w;
    size_t size = table_fixture_encode(&fx, &b);
    w = malloc(size);
    const uint64_t pb = le64(b + 96), pn = le64(b + 104);
    assert_int_equal(pn, pb + 16 + 2 * 8);
    struct {
        uint64_t at;
        double f;
        int ok;
    } cases[] = {
        {pn, -100.0, 1},      {pn, nextafter(-100.0, -200.0), 0},
        {pn, 300.0, 1},       {pn, nextafter(300.0, 400.0), 0},
        {pn, NAN, 0},         {pn, -INFINITY, 0},
        {pn + 8, 0.05, 1},    {pn + 8, -0.05, 1},
        {pn + 8, 0.0, 1},     {pn + 8, nextafter(0.05, 1.0), 0},
        {pn + 8, NAN, 0},     {pn + 16, 1e-300, 0},
        {pn + 24, 1e-300, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        memcpy(w, b, size);
        put_f64(w + cases[i].at, cases[i].f);
        char what[32];
        snprintf(what, sizeof what, "panel case %zu", i);
        expect(w, size, cases[i].ok ? 0 : HAPTIC_TABLE_EFIELD, NULL, cases[i].ok ? UINT64_MAX : cases[i].at, what);
    }
    /* It must not overlap the playback section. */
    memcpy(w, b, size);
    put(w + 104, 8, pn - 8);
    expect(w, size, HAPTIC_TABLE_ELAYOUT, "panel_offset", 104, "overlaps playback");
    /* Its flag cleared: the offset field is reserved, then the bytes a gap
     * (23.0 = 0x4037000000000000). */
    memcpy(w, b, size);
    put(w + 16, 4, HAPTIC_TABLE_FLAG_PLAYBACK);
    expect(w, size, HAPTIC_TABLE_EFIELD, "header reserved", 104, "offset without flag");
    put(w + 104, 8, 0);
    expect(w, size, HAPTIC_TABLE_EFIELD, "gap between sections", pn + 6, "section without flag");
    free(w);
    free(b);
    table_fixture_free(&fx);
}

/* 1.3's range section. The fixture with 2 channels, 2 foci: channels at 128
 * (32 bytes), foci at 160 (96), gram at 256 (32), provenance at 288 (256),
 * playback at 544 (16 + 2 x 8), panel at 576 (32), range at 608 (16 + 2 x 16
 * = 48, to 656), payload at 704 (the next multiple of 64). */
static size_t range_table(uint8_t **out)
{
    table_fixture fx;
    table_fixture_init(&fx, 2, 2, 48, 4);
    fx.spec.range = &fx.range; /* focus 0: [0.5, 2), focus 1: [0.25, +inf); 1 um, whole area */
    size_t size = table_fixture_encode(&fx, out);
    table_fixture_free(&fx);
    assert_true(size > 0);
    return size;
}

/* Each field at its documented offset, each bound at its edge, each bad
 * value named at its byte offset with its field. */
static void range_section_is_checked_as_documented(void **state)
{
    (void)state;
    uint8_t *b, *w;
    size_t size = range_table(&b);
    w = malloc(size);
    const uint64_t rg = le64(b + 112), pn = le64(b + 104), pl = le64(b + 80);
    assert_int_equal(le32(b + 16), 0x00070000u);
    assert_int_equal(pn, 576);
    assert_int_equal(rg, 608);
    assert_int_equal(pl, 704);
    /* The writer's bytes: 1 um, scope 1 (u16), 6 reserved zero bytes, then lo, hi per focus. */
    assert_true(get_f64(b + rg) == 1e-6);
    assert_true(b[rg + 8] == 1 && b[rg + 9] == 0);
    for (int k = 10; k < 16; k++)
        assert_int_equal(b[rg + k], 0);
    assert_true(get_f64(b + rg + 16) == 0.5 && get_f64(b + rg + 24) == 2.0);
    assert_true(get_f64(b + rg + 32) == 0.25 && get_f64(b + rg + 40) == INFINITY);
    assert_int_equal(check(b, size, NULL), 0);

    const double max = HAPTIC_TABLE_RANGE_MAX_GAIN, tiny = 4.9406564584124654e-324;
    struct {
        uint64_t at;
        int width;
        double f;
        uint64_t u;
        const char *field;
    } cases[] = {
        /* threshold_m: finite, 0 < t <= 1000 */
        {rg, 8, 1000.0, 0, NULL},
        {rg, 8, tiny, 0, NULL},
        {rg, 8, nextafter(1000.0, 2000.0), 0, "range threshold_m"},
        {rg, 8, 0.0, 0, "range threshold_m"},
        {rg, 8, -0.0, 0, "range threshold_m"},
        {rg, 8, -1e-6, 0, "range threshold_m"},
        {rg, 8, NAN, 0, "range threshold_m"},
        {rg, 8, INFINITY, 0, "range threshold_m"},
        {rg, 8, -INFINITY, 0, "range threshold_m"},
        /* scope: 1 or 2 */
        {rg + 8, 2, 0, 2, NULL},
        {rg + 8, 2, 0, 0, "range scope"},
        {rg + 8, 2, 0, 3, "range scope"},
        {rg + 8, 2, 0, 0xFFFF, "range scope"},
        {rg + 8, 2, 0, 0x0101, "range scope"},
        /* reserved: u16 at +10, u32 at +12 */
        {rg + 10, 2, 0, 1, "range reserved"},
        {rg + 11, 1, 0, 0x80, "range reserved"},
        {rg + 12, 4, 0, 1, "range reserved"},
        {rg + 15, 1, 0, 0x80, "range reserved"},
        /* gain_lo: finite, 0 < lo <= 1e6 */
        {rg + 16, 8, max, 0, NULL},
        {rg + 16, 8, tiny, 0, NULL},
        {rg + 16, 8, nextafter(max, 2 * max), 0, "focus 0 gain_lo"},
        {rg + 16, 8, 0.0, 0, "focus 0 gain_lo"},
        {rg + 16, 8, -0.0, 0, "focus 0 gain_lo"},
        {rg + 16, 8, -0.5, 0, "focus 0 gain_lo"},
        {rg + 16, 8, NAN, 0, "focus 0 gain_lo"},
        {rg + 16, 8, INFINITY, 0, "focus 0 gain_lo"},
        {rg + 16, 8, -INFINITY, 0, "focus 0 gain_lo"},
        {rg + 32, 8, -NAN, 0, "focus 1 gain_lo"},
        /* gain_hi: 0 < hi <= 1e6, or +inf; lo >= hi allowed (a failing focus) */
        {rg + 24, 8, max, 0, NULL},
        {rg + 24, 8, INFINITY, 0, NULL},
        {rg + 24, 8, 0.5, 0, NULL},
        {rg + 24, 8, tiny, 0, NULL},
        {rg + 24, 8, nextafter(max, 2 * max), 0, "focus 0 gain_hi"},
        {rg + 24, 8, 0.0, 0, "focus 0 gain_hi"},
        {rg + 24, 8, -0.0, 0, "focus 0 gain_hi"},
        {rg + 24, 8, -2.0, 0, "focus 0 gain_hi"},
        {rg + 24, 8, NAN, 0, "focus 0 gain_hi"},
        {rg + 24, 8, -INFINITY, 0, "focus 0 gain_hi"},
        {rg + 40, 8, 0.0, 0, "focus 1 gain_hi"},
        {rg + 40, 8, 1e6, 0, NULL},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        memcpy(w, b, size);
        if (cases[i].width == 8)
            put_f64(w + cases[i].at, cases[i].f);
        else
            put(w + cases[i].at, (size_t)cases[i].width, cases[i].u);
        char what[48];
        snprintf(what, sizeof what, "range case %zu (%s)", i, cases[i].field ? cases[i].field : "accepted");
        /* Named at the field (a reserved byte: the first non-zero one, here the edited one). */
        expect(w, size, cases[i].field ? HAPTIC_TABLE_EFIELD : 0, cases[i].field,
               cases[i].field ? cases[i].at : UINT64_MAX, what);
    }
    /* Checked in order: the threshold before the scope, focus 0 before focus 1, lo before hi. */
    memcpy(w, b, size);
    put(w + rg + 8, 2, 9);
    put_f64(w + rg, 0.0);
    expect(w, size, HAPTIC_TABLE_EFIELD, "range threshold_m", rg, "threshold before scope");
    memcpy(w, b, size);
    put_f64(w + rg + 40, -1.0);
    put_f64(w + rg + 24, NAN);
    put_f64(w + rg + 16, -1.0);
    expect(w, size, HAPTIC_TABLE_EFIELD, "focus 0 gain_lo", rg + 16, "lo before hi, focus 0 first");
    /* Step 10: after the panel section, before the Gram matrix. */
    memcpy(w, b, size);
    put_f64(w + rg + 16, 0.0);
    put_f64(w + le64(b + 64) + 8, 1e30); /* gram[0][1] */
    put_f64(w + le64(b + 64) + 16, 1e30);
    expect(w, size, HAPTIC_TABLE_EFIELD, "focus 0 gain_lo", rg + 16, "range before Gram");
    put_f64(w + pn, 301.0);
    expect(w, size, HAPTIC_TABLE_EFIELD, "panel temperature_c", pn, "panel before range");
    free(w);
    free(b);
}

/* Step 5: the section lies after the panel section (the playback section,
 * the provenance), 8-aligned, wholly before the payload; the writer places
 * it right after, but a zero gap before it is allowed. */
static void range_section_placement(void **state)
{
    (void)state;
    uint8_t *b, *w;
    size_t size = range_table(&b);
    w = malloc(size);
    const uint64_t rg = 608, pl = 704;
    struct {
        uint64_t off;
        const char *needle;
    } bad[] = {
        {rg - 8, "overlaps a previous section"}, /* inside the panel section (576..608) */
        {rg + 4, "is not a multiple of 8"},
        {0, "overlaps a previous section"},
        {UINT64_MAX - 7, "overlaps a previous section"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        memcpy(w, b, size);
        put(w + 112, 8, bad[i].off);
        char what[40];
        snprintf(what, sizeof what, "range_offset %llu", (unsigned long long)bad[i].off);
        expect(w, size, HAPTIC_TABLE_ELAYOUT, "range_offset", 112, what);
        expect(w, size, HAPTIC_TABLE_ELAYOUT, bad[i].needle, 112, what);
    }
    /* 48 bytes from 664 run into the payload at 704: the payload's floor is the section's end. */
    memcpy(w, b, size);
    put(w + 112, 8, pl - 40);
    expect(w, size, HAPTIC_TABLE_ELAYOUT, "payload_offset", 80, "range into the payload");
    /* Moved later by 8 behind a zero gap: 616..664, still before the payload. */
    memcpy(w, b, size);
    memmove(w + rg + 8, w + rg, 48);
    memset(w + rg, 0, 8);
    put(w + 112, 8, rg + 8);
    expect(w, size, 0, NULL, UINT64_MAX, "range moved by 8");
    w[rg + 3] = 1; /* the gap is a gap: zero */
    expect(w, size, HAPTIC_TABLE_EFIELD, "gap between sections", rg + 3, "gap before the range section");
    /* Without the panel section it follows the playback section (576). */
    table_fixture fx;
    table_fixture_init(&fx, 2, 2, 48, 4);
    fx.spec.range = &fx.range;
    fx.spec.panel = NULL;
    uint8_t *np;
    size_t nsize = table_fixture_encode(&fx, &np);
    assert_int_equal(le64(np + 104), 0);
    assert_int_equal(le64(np + 112), 576);
    put(np + 112, 8, 568); /* inside the playback section (544..576) */
    expect(np, nsize, HAPTIC_TABLE_ELAYOUT, "range_offset", 112, "overlaps playback");
    free(np);
    /* Without playback and panel sections: right after the provenance (544). */
    fx.spec.drive_kind = HAPTIC_DRIVE_UNKNOWN;
    nsize = table_fixture_encode(&fx, &np);
    assert_int_equal(le64(np + 112), 544);
    assert_int_equal(le32(np + 16), HAPTIC_TABLE_FLAG_RANGE);
    put(np + 112, 8, 536);
    expect(np, nsize, HAPTIC_TABLE_ELAYOUT, "range_offset", 112, "overlaps provenance");
    free(np);
    table_fixture_free(&fx);
    free(w);
    free(b);
}

/* Versioning as for 1.1 and 1.2: the flag and bytes 112..119 are unknown
 * (must be 0) in a known minor < 3; a 1.3 file without the flag has them 0;
 * a later minor ignores unknown things but the section is still checked. */
static void range_section_versioning(void **state)
{
    (void)state;
    uint8_t *b, *w;
    size_t size = range_table(&b);
    w = malloc(size);
    const uint64_t rg = 608;
    /* The same file called 1.2 or 1.1: the flag is an unknown optional bit there. */
    const uint16_t older[] = {2, 1};
    for (size_t i = 0; i < 2; i++) {
        memcpy(w, b, size);
        put(w + 10, 2, older[i]);
        char needle[64];
        snprintf(needle, sizeof needle, "optional bits 0x%08x unknown in version 1.%u",
                 older[i] == 2 ? 0x00040000u : 0x00060000u, (unsigned)older[i]);
        expect(w, size, HAPTIC_TABLE_EFIELD, needle, 16, needle);
    }
    /* In 1.2 the flag is unknown, so the layout (step 5) does not look for the
     * section: an offset no 1.3 reader would take is named at the flag (step 7). */
    memcpy(w, b, size);
    put(w + 10, 2, 2);
    put(w + 112, 8, 4);
    expect(w, size, HAPTIC_TABLE_EFIELD, "optional bits 0x00040000 unknown in version 1.2", 16, "1.2, bad offset");
    put(w + 10, 2, 3);
    expect(w, size, HAPTIC_TABLE_ELAYOUT, "range_offset", 112, "1.3, bad offset");
    /* 1.2 with the flag cleared: the offset is reserved, then the section's bytes are a gap
     * (1e-6 = 0x3EB0C6F7A0B5ED8D: its first byte 0x8D). */
    memcpy(w, b, size);
    put(w + 10, 2, 2);
    put(w + 16, 4, 0x00030000u);
    expect(w, size, HAPTIC_TABLE_EFIELD, "header reserved", 112, "1.2, offset without flag");
    put(w + 112, 8, 0);
    expect(w, size, HAPTIC_TABLE_EFIELD, "gap between sections", rg, "1.2, section without flag");
    /* The same in 1.3. */
    put(w + 10, 2, 3);
    expect(w, size, HAPTIC_TABLE_EFIELD, "gap between sections", rg, "1.3, section without flag");
    put(w + 112, 8, rg);
    expect(w, size, HAPTIC_TABLE_EFIELD, "header reserved", 112, "1.3, offset without flag");
    /* A later minor ignores the bytes and the section it does not announce... */
    put(w + 10, 2, 4);
    expect(w, size, 0, NULL, UINT64_MAX, "1.4, offset without flag");
    /* ...and still checks the section it announces. */
    memcpy(w, b, size);
    put(w + 10, 2, 4);
    put_f64(w + rg + 24, -1.0);
    expect(w, size, HAPTIC_TABLE_EFIELD, "focus 0 gain_hi", rg + 24, "1.4, bad hi");
    put_f64(w + rg + 24, 2.0);
    w[126] = 0x55; /* bytes 120..127 are a later minor's */
    expect(w, size, 0, NULL, UINT64_MAX, "1.4, byte 126");
    put(w + 10, 2, 3);
    expect(w, size, HAPTIC_TABLE_EFIELD, "header reserved", 126, "1.3, byte 126");
    free(w);
    free(b);

    /* A 1.2 file as the 1.2 writer wrote it (the writer's bytes with its
     * minor: nothing in 112..127) is read, without a range. */
    table_fixture fx;
    table_fixture_init(&fx, 2, 2, 48, 4);
    size = table_fixture_encode(&fx, &b);
    table_fixture_free(&fx);
    for (int k = 112; k < 128; k++)
        assert_int_equal(b[k], 0);
    assert_int_equal(b[10], 3); /* the writer writes 1.3, with or without the section */
    haptic_table t;
    haptic_gain_range r = {-1, -1};
    for (uint16_t minor = 2; minor <= 3; minor++) {
        put(b + 10, 2, minor);
        table_fixture_fix_crc(b, size);
        assert_int_equal(check(b, size, NULL), 0);
        assert_int_equal(haptic_table_validate(b, size, &t, NULL), 0);
        assert_int_equal(t.format_minor, minor);
        assert_int_equal(t.range_offset, 0);
        assert_int_equal(haptic_table_gain_range(&t, 0, &r), -1);
        assert_true(r.lo == -1 && r.hi == -1);
        assert_true(isnan(haptic_table_range_threshold_m(&t)));
        assert_int_equal(haptic_table_range_scope(&t), 0);
        /* The 1.3 reserved bytes 112..119 set in a file without the section. */
        b[115] = 1;
        expect(b, size, HAPTIC_TABLE_EFIELD, "header reserved", 115, "112..119 without the section");
        b[115] = 0;
    }
    free(b);
}

/* Writer -> reader: every value read back bit for bit, +inf and a failing
 * focus (lo >= hi) included; the writer refuses what the reader refuses. */
static void range_section_round_trips(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 3, 4, 32, 8);
    const haptic_gain_range want[4] = {
        {0.31622776601683794, 3.1622776601683795}, /* -10..+10 dB */
        {1e-300, INFINITY},
        {2.0, 0.5}, /* fails at every gain */
        {HAPTIC_TABLE_RANGE_MAX_GAIN, HAPTIC_TABLE_RANGE_MAX_GAIN},
    };
    memcpy(fx.gain_range, want, sizeof want);
    fx.range.threshold_m = 2.5e-7;
    fx.range.scope = HAPTIC_RANGE_FOCI_ONLY;
    fx.spec.range = &fx.range;
    char path[] = "/tmp/range-XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    haptic_table_error err;
    if (haptic_table_write(path, &fx.spec, &err) != 0)
        fail_msg("%s", err.message);
    haptic_table t;
    if (haptic_table_open(path, &t, &err) != 0)
        fail_msg("%s", err.message);
    unlink(path);
    assert_int_equal(t.format_minor, 3);
    assert_int_equal(t.flags, 0x00070000u);
    assert_true(haptic_table_range_threshold_m(&t) == 2.5e-7);
    assert_int_equal(haptic_table_range_scope(&t), HAPTIC_RANGE_FOCI_ONLY);
    for (uint32_t f = 0; f < 4; f++) {
        haptic_gain_range r;
        assert_int_equal(haptic_table_gain_range(&t, f, &r), 0);
        assert_memory_equal(&r, &want[f], sizeof r);
    }
    haptic_gain_range r;
    assert_int_equal(haptic_table_gain_range(&t, 4, &r), -1);
    assert_int_equal(haptic_table_gain_range(&t, 0, NULL), -1);
    haptic_table_close(&t);
    /* What the reader refuses, the writer does not write. */
    fx.gain_range[1].lo = NAN;
    uint8_t buf[4096];
    assert_true(haptic_table_encoded_size(&fx.spec) <= sizeof buf);
    assert_int_equal(haptic_table_encode(&fx.spec, buf, sizeof buf, &err), HAPTIC_TABLE_EFIELD);
    assert_non_null(strstr(err.message, "focus 1 gain_lo"));
    fx.gain_range[1].lo = 1.0;
    fx.range.scope = 0;
    assert_int_equal(haptic_table_encode(&fx.spec, buf, sizeof buf, &err), HAPTIC_TABLE_EFIELD);
    assert_non_null(strstr(err.message, "range scope"));
    fx.range.scope = HAPTIC_RANGE_WHOLE_AREA;
    fx.range.focus = NULL;
    assert_int_equal(haptic_table_encode(&fx.spec, buf, sizeof buf, &err), HAPTIC_TABLE_EINVAL);
    assert_int_equal(haptic_table_encoded_size(&fx.spec), 0);
    table_fixture_free(&fx);
}

/* The summary's range: the threshold and scope once, per focus lo..hi in dB
 * against the stored level, "unbounded" for +inf, "none" for lo >= hi;
 * "unknown" without the section. */
static void summary_prints_the_safe_range(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 2, 3, 48, 4);
    fx.gain_range[2].lo = 4.0; /* the fixture's focus 2 is 1/6..+inf: made a failing one */
    fx.gain_range[2].hi = 3.0;
    fx.spec.range = &fx.range;
    uint8_t *b;
    size_t size = table_fixture_encode(&fx, &b);
    haptic_table t;
    assert_int_equal(haptic_table_validate(b, size, &t, NULL), 0);
    char text[4096] = {0};
    FILE *f = fmemopen(text, sizeof text - 1, "w");
    assert_int_equal(haptic_table_print_summary(&t, "t", f), 0);
    fclose(f);
    /* 20 log10(0.5) = -6.02, 20 log10(2) = +6.02, 20 log10(0.25) = -12.04. */
    assert_non_null(strstr(text, "format 1.3"));
    assert_non_null(strstr(text, "range        threshold 1 um over the whole active area (scope 1); per focus 'safe'"));
    assert_non_null(strstr(text, "focus id 10  "));
    assert_non_null(strstr(text, " ms  safe -6.0..+6.0 dB\n"));
    assert_non_null(strstr(text, " ms  safe -12.0..+12.0 dB\n")); /* focus 1: 0.25..4 */
    assert_non_null(strstr(text, "safe none: fails at every gain\n"));
    free(b);
    fx.gain_range[2].lo = 0.5 / 3;
    fx.gain_range[2].hi = INFINITY;
    fx.range.scope = HAPTIC_RANGE_FOCI_ONLY;
    size = table_fixture_encode(&fx, &b);
    assert_int_equal(haptic_table_validate(b, size, &t, NULL), 0);
    memset(text, 0, sizeof text);
    f = fmemopen(text, sizeof text - 1, "w");
    assert_int_equal(haptic_table_print_summary(&t, "t", f), 0);
    fclose(f);
    assert_non_null(strstr(text, "threshold 1 um over the other foci only (scope 2)"));
    assert_non_null(strstr(text, "safe -15.6 dB..unbounded\n")); /* 20 log10(1/6) */
    free(b);
    fx.spec.range = NULL;
    size = table_fixture_encode(&fx, &b);
    assert_int_equal(haptic_table_validate(b, size, &t, NULL), 0);
    memset(text, 0, sizeof text);
    f = fmemopen(text, sizeof text - 1, "w");
    assert_int_equal(haptic_table_print_summary(&t, "t", f), 0);
    fclose(f);
    assert_non_null(strstr(text, "range        unknown (no range section"));
    assert_null(strstr(text, "safe "));
    free(b);
    table_fixture_free(&fx);
}

/* A table written by the 1.0 writer (tests/common/data): it loads, and what
 * 1.0 does not say is reported as unknown. */
static void a_format_1_0_table_still_loads(void **state)
{
    (void)state;
    haptic_table t;
    haptic_table_error err;
    if (haptic_table_open(TABLE_1_0_PATH, &t, &err) != 0)
        fail_msg("%s", err.message);
    assert_int_equal(t.format_minor, 0);
    assert_int_equal(t.focus_count, 3);
    assert_true(isnan(haptic_table_force_full_scale_n(&t)));
    assert_int_equal(haptic_table_drive_kind(&t), HAPTIC_DRIVE_UNKNOWN);
    haptic_focus_info fi;
    assert_int_equal(haptic_table_focus(&t, 2, &fi), 0);
    assert_int_equal(fi.id, 30);
    assert_true(fi.scale_m == 3.0000000000000004e-05 && isnan(fi.lead_time_s));
    /* Its Gram matrix, from the 1.0 writer, agrees with this reader's sums. */
    assert_true(haptic_table_gram(&t, 1, 0) == -430899121.0 && haptic_table_gram(&t, 2, 2) == 12083798582.0);
    char text[4096] = {0};
    FILE *f = fmemopen(text, sizeof text - 1, "w");
    assert_int_equal(haptic_table_print_summary(&t, "t", f), 0);
    fclose(f);
    assert_non_null(strstr(text, "format 1.0"));
    assert_non_null(strstr(text, "drive        unknown"));
    assert_non_null(strstr(text, "lead ?"));
    /* 1.0 defines no flag: the playback flag in a 1.0 file is an unknown one. */
    uint8_t *b = malloc(t.size);
    memcpy(b, t.data, t.size);
    put(b + 16, 4, 0x00010000u);
    expect(b, t.size, HAPTIC_TABLE_EFIELD, "optional bits 0x00010000", 16, "1.0 with the flag");
    free(b);
    haptic_table_close(&t);
}

static void summary_prints_the_playback_facts(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 2, 2, 480, 4);
    fx.spec.scene_hash = NULL; /* empty: printed as unknown */
    uint8_t *b;
    size_t size = table_fixture_encode(&fx, &b);
    haptic_table t;
    assert_int_equal(haptic_table_validate(b, size, &t, NULL), 0);
    char text[4096] = {0};
    FILE *f = fmemopen(text, sizeof text - 1, "w");
    assert_int_equal(haptic_table_print_summary(&t, "t", f), 0);
    fclose(f);
    assert_non_null(strstr(text, "format 1.3"));
    assert_non_null(strstr(text, "hash (unknown)"));
    assert_non_null(strstr(text, "panel        calibrated at 23.0 C, dE/E/dT -0.4 %/K"));
    assert_non_null(strstr(text, "exciter drive (Bl i), full scale (32767) = 2.5 N, 7.62963e-05 N per count"));
    assert_non_null(strstr(text, "lead 2.5 ms"));
    assert_non_null(strstr(text, "lead time    2.5..5.0 ms"));
    free(b);
    table_fixture_free(&fx);
}

/* Which fault is named when there are several: the document's order. */
static void faults_are_reported_in_the_documented_order(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 2, 3, 8, 6);
    fx.spec.panel = NULL; /* the gap before the payload follows the playback section */
    uint8_t *b, *w;
    size_t size = table_fixture_encode(&fx, &b);
    w = malloc(size);
    const uint64_t gr = le64(b + 64), pr = le64(b + 72), fo = le64(b + 56), pl = le64(b + 80);
    /* Only the upper element differs: the lower one, gram[1][0], is named. */
    memcpy(w, b, size);
    put_f64(w + gr + 8 * 1, 1.0);
    expect(w, size, HAPTIC_TABLE_EGRAM, "gram[1][0]", gr + 8 * 3, "upper element");
    /* gram[2][1] and gram[1][0] both wrong: row 1 comes first. */
    memcpy(w, b, size);
    put_f64(w + gr + 8 * 7, 1e30);
    put_f64(w + gr + 8 * 3, 1e30);
    expect(w, size, HAPTIC_TABLE_EGRAM, "gram[1][0]", gr + 8 * 3, "two Gram faults");
    /* A Gram fault before a provenance fault, a record fault before both. */
    memcpy(w, b, size);
    put_f64(w + gr + 8 * 7, 1e30);
    w[pr] = 0x07;
    expect(w, size, HAPTIC_TABLE_EGRAM, "gram[2][1]", gr + 8 * 7, "Gram before provenance");
    put_f64(w + fo + 48 + 24, -1.0);
    expect(w, size, HAPTIC_TABLE_EFIELD, "focus 1 scale_m", fo + 48 + 24, "records before Gram");
    /* Provenance before the payload comparison; a gap before everything else. */
    memcpy(w, b, size);
    w[pr] = 0x07;
    w[pl + 5] ^= 0x40;
    expect(w, size, HAPTIC_TABLE_EFIELD, "control character", pr, "provenance before payload");
    w[pl - 1] = 1;
    expect(w, size, HAPTIC_TABLE_EFIELD, "gap between sections", pl - 1, "gap first");
    free(w);
    free(b);
    table_fixture_free(&fx);
}

/* A copy of table b with n zero bytes inserted at `at`: every section offset
 * at or after `at` and file_size move by n, the CRC is re-made. */
static uint8_t *insert_zeros(const uint8_t *b, size_t size, uint64_t at, size_t n)
{
    uint8_t *w = calloc(1, size + n);
    memcpy(w, b, at);
    memcpy(w + at + n, b + at, size - at);
    put(w + 40, 8, size + n);
    static const size_t offset_fields[] = {48, 56, 64, 72, 80, 96, 104, 112};
    for (size_t i = 0; i < sizeof offset_fields / sizeof *offset_fields; i++) {
        uint64_t off = le64(w + offset_fields[i]);
        if (off != 0 && off >= at)
            put(w + offset_fields[i], 8, off + n);
    }
    table_fixture_fix_crc(w, size + n);
    return w;
}

static size_t fixture_table(uint8_t **b)
{
    table_fixture fx;
    table_fixture_init(&fx, 2, 2, 16, 21);
    size_t size = table_fixture_encode(&fx, b);
    table_fixture_free(&fx);
    assert_true(size > 0);
    return size;
}

/* Step 5: the payload ends exactly where the CRC trailer starts. Bytes between
 * them (zero or not, the CRC covering them) are refused at payload_offset;
 * the payload itself may lie later than the writer puts it, behind a zero gap. */
static void payload_ends_exactly_at_the_crc_trailer(void **state)
{
    (void)state;
    uint8_t *b;
    size_t size = fixture_table(&b);
    const uint64_t pl = le64(b + 80), ps = le64(b + 88);
    assert_true(pl + ps == size - 4);
    const size_t extra[] = {1, 2, 8, 64};
    for (size_t i = 0; i < sizeof extra / sizeof *extra; i++) {
        uint8_t *w = insert_zeros(b, size, size - 4, extra[i]);
        expect(w, size + extra[i], HAPTIC_TABLE_ELAYOUT, "payload must end where the CRC trailer starts", 80,
               "zero bytes before the trailer");
        memset(w + size - 4, 0xA5, extra[i]);
        expect(w, size + extra[i], HAPTIC_TABLE_ELAYOUT, "payload must end where the CRC trailer starts", 80,
               "unchecked bytes before the trailer");
        free(w);
    }
    uint8_t *w = insert_zeros(b, size, pl, 64); /* payload 64 bytes later, ending at the trailer */
    assert_int_equal(le64(w + 80), pl + 64);
    expect(w, size + 64, 0, NULL, UINT64_MAX, "payload moved by 64");
    free(w);
    free(b);
}

/* Step 5: the payload is 64-byte aligned (the other sections 8-byte). A
 * payload moved by a multiple of 8 that is not one of 64, behind a zero gap,
 * is refused at payload_offset; moved by 64 it is accepted. */
static void payload_offset_is_a_multiple_of_64(void **state)
{
    (void)state;
    uint8_t *b;
    size_t size = fixture_table(&b);
    const uint64_t pl = le64(b + 80);
    assert_int_equal(pl % 64, 0);
    const size_t shift[] = {2, 8, 16, 32, 48, 56, 64, 128};
    for (size_t i = 0; i < sizeof shift / sizeof *shift; i++) {
        uint8_t *w = insert_zeros(b, size, pl, shift[i]);
        char what[40];
        snprintf(what, sizeof what, "payload moved by %zu", shift[i]);
        if (shift[i] % 64 == 0)
            expect(w, size + shift[i], 0, NULL, UINT64_MAX, what);
        else
            expect(w, size + shift[i], HAPTIC_TABLE_ELAYOUT, "is not a multiple of 64", 80, what);
        free(w);
    }
    free(b);
}

/* Which code a size fault gets: a file shorter than its header or its
 * file_size says is truncated (ETRUNC: at the file's length inside the
 * header, at file_size's offset 40 after it); a file longer than its
 * file_size, or whose sections disagree with the counts, is a layout fault
 * (ELAYOUT). */
static void truncation_is_etrunc_and_inconsistent_layout_is_elayout(void **state)
{
    (void)state;
    uint8_t *b;
    size_t size = fixture_table(&b);
    haptic_table_error err;
    for (size_t len = 0; len < size; len++) {
        int rc = check(b, len, &err);
        uint64_t at = len < 128 ? len : 40;
        const char *needle = len < 128 ? "ends inside the header" : "(file_size): header says";
        if (rc != HAPTIC_TABLE_ETRUNC || err.offset != at || !strstr(err.message, needle))
            fail_msg("truncated to %zu of %zu: rc %d at %llu (%s), want ETRUNC at %llu", len, size, rc,
                     (unsigned long long)err.offset, err.message, (unsigned long long)at);
    }
    const size_t extra[] = {1, 4, 64};
    for (size_t i = 0; i < sizeof extra / sizeof *extra; i++) {
        uint8_t *w = calloc(1, size + extra[i]);
        memcpy(w, b, size);
        int rc = check(w, size + extra[i], &err);
        if (rc != HAPTIC_TABLE_ELAYOUT || err.offset != 40 || !strstr(err.message, "(file_size): header says"))
            fail_msg("%zu bytes appended: rc %d at %llu (%s), want ELAYOUT at 40", extra[i], rc,
                     (unsigned long long)err.offset, err.message);
        free(w);
    }
    /* A file_size below or above the real size, the CRC re-made. */
    uint8_t *w = malloc(size);
    memcpy(w, b, size);
    put(w + 40, 8, size - 8);
    expect(w, size, HAPTIC_TABLE_ELAYOUT, "(file_size): header says", 40, "file_size too small");
    put(w + 40, 8, size + 8);
    expect(w, size, HAPTIC_TABLE_ETRUNC, "(file_size): header says", 40, "file_size too large");
    /* payload_size that disagrees with the counts. */
    memcpy(w, b, size);
    put(w + 88, 8, le64(b + 88) + 2);
    expect(w, size, HAPTIC_TABLE_ELAYOUT, "(payload_size)", 88, "payload_size + 2");
    free(w);
    free(b);
}

/* header_size: 128 in a known minor; in a later one (1.4 here) a multiple
 * of 8 in 128..4096, the channels section at or after it. The sections are
 * moved 64 bytes later so header sizes up to 192 fit. */
static void header_size_of_a_later_minor_is_a_multiple_of_8(void **state)
{
    (void)state;
    uint8_t *b;
    size_t size = fixture_table(&b);
    uint8_t *w = insert_zeros(b, size, 128, 64);
    size += 64;
    assert_int_equal(le64(w + 48), 192);
    struct {
        uint16_t minor;
        uint32_t header_size;
        int want;
        uint64_t at;
        const char *needle;
    } cases[] = {
        {2, 128, 0, 0, NULL},
        {2, 136, HAPTIC_TABLE_EFIELD, 12, "version 1.2 has 128"},
        {3, 128, 0, 0, NULL},
        {3, 136, HAPTIC_TABLE_EFIELD, 12, "version 1.3 has 128"},
        {4, 128, 0, 0, NULL},
        {4, 136, 0, 0, NULL},
        {4, 192, 0, 0, NULL},
        {4, 129, HAPTIC_TABLE_EFIELD, 12, "expected a multiple of 8"},
        {4, 132, HAPTIC_TABLE_EFIELD, 12, "expected a multiple of 8"},
        {4, 188, HAPTIC_TABLE_EFIELD, 12, "expected a multiple of 8"},
        {4, 191, HAPTIC_TABLE_EFIELD, 12, "expected a multiple of 8"},
        {4, 120, HAPTIC_TABLE_EFIELD, 12, "expected a multiple of 8"},
        {4, 4104, HAPTIC_TABLE_EFIELD, 12, "expected a multiple of 8"},
        {4, 200, HAPTIC_TABLE_ELAYOUT, 48, "channels_offset"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        put(w + 10, 2, cases[i].minor);
        put(w + 12, 4, cases[i].header_size);
        char what[48];
        snprintf(what, sizeof what, "1.%u header_size %lu", (unsigned)cases[i].minor,
                 (unsigned long)cases[i].header_size);
        expect(w, size, cases[i].want, cases[i].needle, cases[i].want ? cases[i].at : UINT64_MAX, what);
    }
    free(w);
    free(b);
}

/* Focus scale_m: finite, 0 < scale_m <= 1000 (0 and -0 refused, the
 * smallest positive double accepted). */
static void focus_scale_m_is_positive_and_at_most_1000(void **state)
{
    (void)state;
    uint8_t *b;
    size_t size = fixture_table(&b);
    uint8_t *w = malloc(size);
    const uint64_t at = le64(b + 56) + 48 + 24; /* focus 1 scale_m */
    struct {
        double v;
        int ok;
    } cases[] = {
        {0.0, 0},      {-0.0, 0},   {4.9406564584124654e-324, 1},   {2.2250738585072014e-308, 1},
        {1e-5, 1},     {1000.0, 1}, {nextafter(1000.0, 2000.0), 0}, {-1e-5, 0},
        {INFINITY, 0}, {NAN, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        memcpy(w, b, size);
        put_f64(w + at, cases[i].v);
        char what[40];
        snprintf(what, sizeof what, "scale_m case %zu (%g)", i, cases[i].v);
        expect(w, size, cases[i].ok ? 0 : HAPTIC_TABLE_EFIELD, cases[i].ok ? NULL : "focus 1 scale_m",
               cases[i].ok ? UINT64_MAX : at, what);
    }
    free(w);
    free(b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(gram_and_energies_are_the_exact_sums),
        cmocka_unit_test(an_altered_gram_or_payload_under_a_fresh_crc_is_refused),
        cmocka_unit_test(energy_above_2_pow_53_is_the_exact_sum_rounded_once),
        cmocka_unit_test(off_diagonal_check_follows_the_documented_cost_bound),
        cmocka_unit_test(cauchy_schwarz_slack_is_1e_9_above_the_cost_bound),
        cmocka_unit_test(cauchy_schwarz_is_named_before_the_payload_comparison),
        cmocka_unit_test(focus_ids_0_and_ffffffff_are_ordinary_and_repeats_are_named),
        cmocka_unit_test(reserved_bytes_and_gaps_are_zero_up_to_the_known_minor),
        cmocka_unit_test(provenance_text_is_checked_as_documented),
        cmocka_unit_test(playback_section_is_checked_as_documented),
        cmocka_unit_test(panel_section_is_checked_as_documented),
        cmocka_unit_test(range_section_is_checked_as_documented),
        cmocka_unit_test(range_section_placement),
        cmocka_unit_test(range_section_versioning),
        cmocka_unit_test(range_section_round_trips),
        cmocka_unit_test(summary_prints_the_safe_range),
        cmocka_unit_test(a_format_1_0_table_still_loads),
        cmocka_unit_test(summary_prints_the_playback_facts),
        cmocka_unit_test(faults_are_reported_in_the_documented_order),
        cmocka_unit_test(payload_ends_exactly_at_the_crc_trailer),
        cmocka_unit_test(payload_offset_is_a_multiple_of_64),
        cmocka_unit_test(truncation_is_etrunc_and_inconsistent_layout_is_elayout),
        cmocka_unit_test(header_size_of_a_later_minor_is_a_multiple_of_8),
        cmocka_unit_test(focus_scale_m_is_positive_and_at_most_1000),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
