/* Table format: round trip, the documented byte layout, the Gram matrix
 * against a brute-force recomputation, the atomic writer, the API's
 * argument checks, and the clamp rule of a focus's safe range. */
#define _POSIX_C_SOURCE 200809L
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include "table_fixture.h"

static uint32_t le32(const uint8_t *p) { return p[0] | p[1] << 8 | p[2] << 16 | (uint32_t)p[3] << 24; }
static uint64_t le64(const uint8_t *p) { return le32(p) | (uint64_t)le32(p + 4) << 32; }

#define TEST_TMPDIR_PREFIX "htab"
#include "test_tmpdir.h"

static int count_dir_entries(void)
{
    int n = 0;
    DIR *d = opendir(tmpdir);
    struct dirent *e;
    while ((e = readdir(d)))
        n += e->d_name[0] != '.';
    closedir(d);
    return n;
}

static void crc32_matches_the_documented_check_value(void **state)
{
    (void)state;
    /* docs/table-format.md: CRC-32/ISO-HDLC (zlib), check value of "123456789". */
    assert_int_equal(crc32(crc32(0L, Z_NULL, 0), (const Bytef *)"123456789", 9), 0xCBF43926u);
}

static void round_trip_is_bit_identical(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 8, 5, 300, 7);
    char path[300];
    snprintf(path, sizeof path, "%s/rt.htab", tmpdir);
    haptic_table_error err;
    assert_int_equal(haptic_table_write(path, &fx.spec, &err), 0);
    assert_int_equal(count_dir_entries(), 1); /* no temporary left behind */

    haptic_table t;
    int rc = haptic_table_open(path, &t, &err);
    if (rc)
        fail_msg("%s", err.message);
    assert_int_equal(t.sample_rate_hz, 48000);
    assert_int_equal(t.channel_count, 8);
    assert_int_equal(t.focus_count, 5);
    assert_int_equal(t.samples_per_signal, 300);
    for (uint32_t c = 0; c < 8; c++) {
        double x, y;
        assert_int_equal(haptic_table_channel_position(&t, c, &x, &y), 0);
        assert_true(x == fx.channel_xy[2 * c] && y == fx.channel_xy[2 * c + 1]);
    }
    for (uint32_t f = 0; f < 5; f++) {
        haptic_focus_info fi;
        assert_int_equal(haptic_table_focus(&t, f, &fi), 0);
        assert_int_equal(fi.id, fx.ids[f]);
        assert_true(fi.x_m == fx.focus_xy[2 * f] && fi.y_m == fx.focus_xy[2 * f + 1]);
        assert_true(fi.scale_m == fx.scale[f]);
        assert_int_equal(haptic_table_find_focus(&t, fx.ids[f]), (int)f);
        assert_memory_equal(haptic_table_signal(&t, f), fx.samples + (size_t)f * 300 * 8, 300 * 8 * sizeof(int16_t));
    }
    assert_int_equal(haptic_table_find_focus(&t, 11), -1);
    haptic_provenance p;
    haptic_table_provenance(&t, &p);
    assert_string_equal(p.scene_name, "fixture");
    assert_string_equal(p.scene_hash, "fnv1a64:0123456789abcdef");
    assert_string_equal(p.tool_version, "test 0");
    assert_string_equal(p.created_utc, "2026-11-21T00:00:00Z");
    haptic_table_close(&t);
    assert_null(t.data);
    table_fixture_free(&fx);
}

static void gram_matrix_equals_brute_force(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 3, 4, 1000, 99);
    uint8_t *b;
    size_t size = table_fixture_encode(&fx, &b);
    assert_true(size > 0);
    haptic_table t;
    assert_int_equal(haptic_table_validate(b, size, &t, NULL), 0);
    const size_t per = 3 * 1000;
    for (uint32_t i = 0; i < 4; i++)
        for (uint32_t j = 0; j < 4; j++) {
            long double acc = 0; /* independent: long double sum of products */
            for (size_t n = 0; n < per; n++)
                acc += (long double)fx.samples[i * per + n] * fx.samples[j * per + n];
            assert_true(haptic_table_gram(&t, i, j) == (double)acc);
        }
    haptic_focus_info fi;
    haptic_table_focus(&t, 2, &fi);
    assert_true(fi.energy == haptic_table_gram(&t, 2, 2));
    free(b);
    table_fixture_free(&fx);
}

static void header_follows_the_documented_layout(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 8, 9, 100, 3);
    uint8_t *b;
    size_t size = table_fixture_encode(&fx, &b);
    /* Offsets and sizes as docs/table-format.md states them. */
    assert_memory_equal(b, "HAPTBL\r\n", 8);
    assert_int_equal(b[8] | b[9] << 8, 1);
    assert_int_equal(b[10] | b[11] << 8, 3);
    assert_int_equal(le32(b + 12), 128);
    assert_int_equal(le32(b + 20), 48000);
    assert_int_equal(b[24] | b[25] << 8, 8);
    assert_int_equal(b[26] | b[27] << 8, 1);
    assert_int_equal(le32(b + 28), 9);
    assert_int_equal(le32(b + 32), 100);
    assert_int_equal(le64(b + 40), size);
    uint64_t ch = le64(b + 48), fo = le64(b + 56), gr = le64(b + 64), pr = le64(b + 72), pl = le64(b + 80);
    assert_int_equal(ch, 128);
    assert_int_equal(fo, 128 + 8 * 16);
    assert_int_equal(gr, fo + 9 * 48);
    assert_int_equal(pr, gr + 9 * 9 * 8);
    /* 1.1: the playback section (16 + 8 K bytes) follows the provenance;
     * 1.2: the panel section (32 bytes) follows it, then the payload. */
    assert_int_equal(le32(b + 16), 0x00030000u);
    uint64_t pb = le64(b + 96), pn = le64(b + 104);
    assert_int_equal(pb, pr + 256);
    assert_int_equal(pn, pb + 16 + 9 * 8);
    double temp, coef;
    uint64_t bits = le64(b + pn);
    memcpy(&temp, &bits, 8);
    bits = le64(b + pn + 8);
    memcpy(&coef, &bits, 8);
    assert_true(temp == 23.0 && coef == -0.004);
    for (int k = 16; k < 32; k++)
        assert_int_equal(b[pn + k], 0);
    for (int k = 112; k < 128; k++) /* no range section (1.3): its offset and the reserved bytes are 0 */
        assert_int_equal(b[k], 0);
    assert_int_equal(pl % 64, 0);
    assert_true(pl >= pn + 32 && pl < pn + 32 + 64);
    assert_int_equal(le64(b + 88), 9 * 100 * 8 * 2);
    assert_int_equal(pl + 9 * 100 * 8 * 2 + 4, size);
    /* Focus 1 record: id at +0, x at +8 (IEEE-754 double, little-endian). */
    assert_int_equal(le32(b + fo + 48), 20);
    uint64_t xbits = le64(b + fo + 48 + 8);
    double x;
    memcpy(&x, &xbits, 8);
    assert_true(x == fx.focus_xy[2]);
    /* Payload: focus 2, frame 5, channel 3 at pl + ((2*100 + 5)*8 + 3)*2. */
    size_t at = pl + ((2 * 100 + 5) * 8 + 3) * 2;
    assert_int_equal((int16_t)(b[at] | b[at + 1] << 8), fx.samples[(2 * 100 + 5) * 8 + 3]);
    /* CRC-32 over [0, size-4). */
    assert_int_equal(le32(b + size - 4), (uint32_t)crc32(crc32(0L, Z_NULL, 0), b, (uInt)(size - 4)));
    free(b);
    table_fixture_free(&fx);
}

static void writer_replaces_atomically_and_fails_cleanly(void **state)
{
    (void)state;
    table_fixture a, b;
    table_fixture_init(&a, 2, 1, 50, 1);
    table_fixture_init(&b, 4, 2, 70, 2);
    char path[300];
    snprintf(path, sizeof path, "%s/replace.htab", tmpdir);
    haptic_table_error err;
    assert_int_equal(haptic_table_write(path, &a.spec, &err), 0);
    assert_int_equal(haptic_table_write(path, &b.spec, &err), 0);
    haptic_table t;
    assert_int_equal(haptic_table_open(path, &t, &err), 0);
    assert_int_equal(t.channel_count, 4);
    haptic_table_close(&t);
    int before = count_dir_entries();

    /* An invalid spec (all-zero focus) is refused and the old file stays. */
    memset(a.samples, 0, 50 * 2 * sizeof(int16_t));
    assert_int_equal(haptic_table_write(path, &a.spec, &err), HAPTIC_TABLE_EGRAM);
    assert_int_equal(count_dir_entries(), before);
    assert_int_equal(haptic_table_open(path, &t, &err), 0);
    assert_int_equal(t.channel_count, 4);
    haptic_table_close(&t);

    /* A directory that does not exist: EIO naming the temporary, nothing created. */
    snprintf(path, sizeof path, "%s/missing/x.htab", tmpdir);
    assert_int_equal(haptic_table_write(path, &b.spec, &err), HAPTIC_TABLE_EIO);
    assert_non_null(strstr(err.message, "missing/x.htab.tmp"));
    assert_int_equal(count_dir_entries(), before);
    table_fixture_free(&a);
    table_fixture_free(&b);
}

static void open_reports_missing_file(void **state)
{
    (void)state;
    haptic_table t;
    haptic_table_error err;
    assert_int_equal(haptic_table_open("/nonexistent/dir/t.htab", &t, &err), HAPTIC_TABLE_EIO);
    assert_non_null(strstr(err.message, "No such file"));
    assert_int_equal(haptic_table_open(tmpdir, &t, &err), HAPTIC_TABLE_EIO); /* a directory */
    assert_null(t.data);
}

/* A FIFO at the table path (a SIGHUP after someone made one there) and a
 * device: refused at once as not regular files, never blocked on. Before the
 * open was non-blocking, the FIFO blocked in open() until a writer came; the
 * alarm turns such a hang into a failure here instead of a ctest timeout. */
static void open_refuses_a_fifo_and_a_device_without_blocking(void **state)
{
    (void)state;
    char fifo[300];
    snprintf(fifo, sizeof fifo, "%s/t.fifo", tmpdir);
    assert_int_equal(mkfifo(fifo, 0600), 0);
    haptic_table t;
    haptic_table_error err;
    alarm(10);
    assert_int_equal(haptic_table_open(fifo, &t, &err), HAPTIC_TABLE_EIO);
    assert_non_null(strstr(err.message, "not a regular file"));
    assert_null(t.data);
    assert_int_equal(haptic_table_open("/dev/zero", &t, &err), HAPTIC_TABLE_EIO);
    assert_non_null(strstr(err.message, "not a regular file"));
    alarm(0);
    assert_int_equal(unlink(fifo), 0);
}

static long peak_rss_kib(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss;
}

/* Sparse file of `size` bytes whose first `n` bytes are `head`. */
static void write_sparse(const char *path, const void *head, size_t n, off_t size)
{
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    assert_true(fd >= 0);
    assert_int_equal(write(fd, head, n), (ssize_t)n);
    assert_int_equal(ftruncate(fd, size), 0);
    close(fd);
}

/* The header is checked before the file is read: a 2 GiB file that is no
 * table, and a real table's header on a file grown to 1 GiB, are refused
 * with the header's own error while the peak memory stays where it was.
 * Before, the whole file was read first (2 GiB resident, 19 s on a board's
 * disk) and only then the magic looked at. */
static void open_checks_the_header_before_reading_the_file(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/sparse.htab", tmpdir);
    haptic_table t;
    haptic_table_error err;
    const long before_kib = peak_rss_kib();
    alarm(10);
    write_sparse(path, "NOTATABLE", 9, (off_t)HAPTIC_TABLE_MAX_FILE_SIZE);
    assert_int_equal(haptic_table_open(path, &t, &err), HAPTIC_TABLE_EMAGIC);
    assert_int_equal(err.offset, 0);
    assert_null(t.data);

    table_fixture fx;
    table_fixture_init(&fx, 8, 3, 200, 5);
    uint8_t *buf;
    size_t size = table_fixture_encode(&fx, &buf);
    assert_true(size > 0);
    write_sparse(path, buf, size, (off_t)1 << 30);
    assert_int_equal(haptic_table_open(path, &t, &err), HAPTIC_TABLE_ELAYOUT);
    assert_int_equal(err.offset, 40); /* file_size: the header disagrees with the file */
    assert_null(t.data);
    /* A file shorter than its header: truncated at its own size. */
    write_sparse(path, buf, 100, 100);
    assert_int_equal(haptic_table_open(path, &t, &err), HAPTIC_TABLE_ETRUNC);
    assert_int_equal(err.offset, 100);
    alarm(0);
    assert_true(peak_rss_kib() - before_kib < 64 * 1024);
    free(buf);
    table_fixture_free(&fx);
    assert_int_equal(unlink(path), 0);
}

static void writer_refuses_bad_specs(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 8, 2, 10, 5);
    haptic_table_error err;
    uint8_t buf[4096];
    haptic_table_spec s = fx.spec;
    s.channel_count = 0;
    assert_int_equal(haptic_table_encode(&s, buf, sizeof buf, &err), HAPTIC_TABLE_EINVAL);
    assert_int_equal(haptic_table_encoded_size(&s), 0);
    s = fx.spec;
    s.channel_count = 33;
    assert_int_equal(haptic_table_encode(&s, buf, sizeof buf, &err), HAPTIC_TABLE_EINVAL);
    s = fx.spec;
    s.sample_rate_hz = 999;
    assert_int_equal(haptic_table_encode(&s, buf, sizeof buf, &err), HAPTIC_TABLE_EINVAL);
    s = fx.spec;
    s.samples = NULL;
    assert_int_equal(haptic_table_encode(&s, buf, sizeof buf, &err), HAPTIC_TABLE_EINVAL);
    s = fx.spec;
    s.scene_name = "a name that is far too long for the sixty-four byte provenance field of the table";
    assert_int_equal(haptic_table_encode(&s, buf, sizeof buf, &err), HAPTIC_TABLE_EINVAL);
    assert_non_null(strstr(err.message, "scene_name"));
    s = fx.spec;
    s.scene_hash = "tab\there";
    assert_int_equal(haptic_table_encode(&s, buf, sizeof buf, &err), HAPTIC_TABLE_EINVAL);
    s = fx.spec;
    fx.ids[1] = fx.ids[0];
    assert_int_equal(haptic_table_encode(&s, buf, sizeof buf, &err), HAPTIC_TABLE_EFIELD);
    assert_non_null(strstr(err.message, "repeats"));
    fx.ids[1] = 20;
    fx.scale[0] = NAN;
    assert_int_equal(haptic_table_encode(&s, buf, sizeof buf, &err), HAPTIC_TABLE_EFIELD);
    fx.scale[0] = 1e-5;
    assert_int_equal(haptic_table_encode(&s, buf, 100, &err), HAPTIC_TABLE_EINVAL); /* buffer too small */
    assert_int_equal(haptic_table_encode(&s, buf, sizeof buf, &err), 0);
    table_fixture_free(&fx);
}

static void accessors_check_their_indices(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 2, 2, 10, 5);
    uint8_t *b;
    size_t size = table_fixture_encode(&fx, &b);
    haptic_table t;
    assert_int_equal(haptic_table_validate(b, size, &t, NULL), 0);
    haptic_focus_info fi;
    assert_int_equal(haptic_table_focus(&t, 2, &fi), HAPTIC_TABLE_EINVAL);
    assert_int_equal(haptic_table_channel_position(&t, 2, NULL, NULL), HAPTIC_TABLE_EINVAL);
    assert_true(isnan(haptic_table_gram(&t, 0, 2)));
    assert_null(haptic_table_signal(&t, 2));
    assert_int_equal(haptic_table_validate(NULL, 10, &t, NULL), HAPTIC_TABLE_EINVAL);
    for (int code = 0; code >= -12; code--)
        assert_non_null(haptic_table_error_string(code));
    FILE *devnull = fopen("/dev/null", "w");
    assert_int_equal(haptic_table_print_summary(&t, "x", devnull), 0);
    fclose(devnull);
    free(b);
    table_fixture_free(&fx);
}

/* 1.2's panel section: read back as written, absent when the writer is not
 * given one (a table of an older minor has none), and a panel flag in a 1.1
 * file is an unknown optional bit there: refused. */
static void panel_section_round_trips_and_is_optional(void **state)
{
    (void)state;
    table_fixture fx;
    table_fixture_init(&fx, 2, 3, 40, 5);
    uint8_t *b;
    size_t size = table_fixture_encode(&fx, &b);
    haptic_table t;
    haptic_panel p;
    assert_int_equal(haptic_table_validate(b, size, &t, NULL), 0);
    assert_int_equal(haptic_table_panel(&t, &p), 0);
    assert_true(p.temperature_c == 23.0 && p.youngs_per_k == -0.004);
    b[10] = 1; /* the same file called 1.1 */
    table_fixture_fix_crc(b, size);
    haptic_table_error err;
    assert_int_equal(haptic_table_validate(b, size, &t, &err), HAPTIC_TABLE_EFIELD);
    assert_non_null(strstr(err.message, "optional bits 0x00020000 unknown in version 1.1"));
    free(b);
    fx.spec.panel = NULL;
    size_t without = table_fixture_encode(&fx, &b);
    /* The playback section then runs straight into the payload's 64-byte alignment. */
    assert_int_equal(le64(b + 80), (le64(b + 96) + 16 + 3 * 8 + 63) / 64 * 64);
    assert_int_equal(without, le64(b + 80) + 3 * 40 * 2 * 2 + 4);
    assert_int_equal(haptic_table_validate(b, without, &t, NULL), 0);
    assert_int_equal(haptic_table_panel(&t, &p), -1);
    assert_int_equal(le32(b + 16), 0x00010000u);
    assert_int_equal(le64(b + 104), 0);
    free(b);
    table_fixture_free(&fx);
}

/* The clamp rule of a safe range (haptic_table.h), by hand: min(max(g, lo),
 * top), top = hi (1 - 1e-6) = 1.999998 for hi = 2; lo >= hi gives the top;
 * clamp(r, 0) is the bottom; an infinite hi bounds nothing above. */
static void gain_range_clamp_rule(void **state)
{
    (void)state;
    const haptic_gain_range r = {0.5, 2.0}, open = {0.5, INFINITY}, failing = {3.0, 2.0}, same = {2.0, 2.0};
    const double top = 2.0 * (1.0 - 1e-6);
    assert_true(top == 1.999998 && top < 2.0);
    struct {
        const haptic_gain_range *r;
        double g, want;
    } cases[] = {
        {&r, 1.0, 1.0},       {&r, 0.5, 0.5},       {&r, 0.1, 0.5},    {&r, 0.0, 0.5},
        {&r, top, top},       {&r, 1.9999985, top}, {&r, 2.0, top},    {&r, 3.0, top},
        {&r, NAN, 0.5},       {&open, 1e9, 1e9},    {&open, 0.1, 0.5}, {&failing, 0.0, top},
        {&failing, 2.5, top}, {&failing, 9.0, top}, {&same, 2.0, top}, {&same, 0.0, top},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        const double got = haptic_gain_range_clamp(cases[i].r, cases[i].g);
        if (got != cases[i].want)
            fail_msg("case %zu: clamp([%g, %g), %g) = %.17g, want %.17g", i, cases[i].r->lo, cases[i].r->hi, cases[i].g,
                     got, cases[i].want);
    }
    /* A hi so small that the margin rounds away: still strictly below it. */
    const haptic_gain_range tiny = {4.9406564584124654e-324, 4.9406564584124654e-324};
    assert_true(haptic_gain_range_clamp(&tiny, 1.0) < tiny.hi);
    /* Foci together: the largest lo, the smallest hi. */
    haptic_gain_range acc = r;
    const haptic_gain_range b = {0.25, 1.5}, c = {1.0, INFINITY};
    haptic_gain_range_intersect(&acc, &b);
    assert_true(acc.lo == 0.5 && acc.hi == 1.5);
    haptic_gain_range_intersect(&acc, &c);
    assert_true(acc.lo == 1.0 && acc.hi == 1.5);
    haptic_gain_range_intersect(&acc, &failing);
    assert_true(acc.lo == 3.0 && acc.hi == 1.5);
    assert_true(haptic_gain_range_clamp(&acc, 1.2) == 1.5 * (1.0 - 1e-6)); /* disjoint: the top */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(crc32_matches_the_documented_check_value),
        cmocka_unit_test(round_trip_is_bit_identical),
        cmocka_unit_test(gram_matrix_equals_brute_force),
        cmocka_unit_test(header_follows_the_documented_layout),
        cmocka_unit_test(writer_replaces_atomically_and_fails_cleanly),
        cmocka_unit_test(open_reports_missing_file),
        cmocka_unit_test(open_refuses_a_fifo_and_a_device_without_blocking),
        cmocka_unit_test(open_checks_the_header_before_reading_the_file),
        cmocka_unit_test(writer_refuses_bad_specs),
        cmocka_unit_test(accessors_check_their_indices),
        cmocka_unit_test(panel_section_round_trips_and_is_optional),
        cmocka_unit_test(gain_range_clamp_rule),
    };
    return cmocka_run_group_tests(tests, make_tmpdir, remove_tmpdir);
}
