/* Corruption sweep: every truncation, every single-bit flip, hostile values
 * in every header field (with the CRC re-made so the field check itself must
 * refuse), inconsistent records. Run under ASan/UBSan by the asan preset:
 * a read out of bounds fails the test even when the verdict is right. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "table_fixture.h"

/* Validate a private, exactly-sized copy so ASan sees any overread. */
static int validate_copy(const uint8_t *b, size_t size, haptic_table_error *err)
{
    uint8_t *copy = malloc(size ? size : 1);
    memcpy(copy, b, size);
    haptic_table t;
    int rc = haptic_table_validate(copy, size, &t, err);
    free(copy);
    return rc;
}

static size_t small_table(uint8_t **b)
{
    table_fixture fx;
    table_fixture_init(&fx, 2, 2, 16, 11);
    size_t size = table_fixture_encode(&fx, b);
    table_fixture_free(&fx);
    assert_true(size > 0);
    return size;
}

static void every_truncation_is_refused(void **state)
{
    (void)state;
    uint8_t *b;
    size_t size = small_table(&b);
    haptic_table_error err;
    for (size_t len = 0; len < size; len++) {
        int rc = validate_copy(b, len, &err);
        if (rc == 0)
            fail_msg("truncation to %zu of %zu bytes accepted", len, size);
        assert_true(strlen(err.message) > 0 && strchr(err.message, '\n') == NULL);
    }
    assert_int_equal(validate_copy(b, size, &err), 0);
    free(b);
}

static void every_single_bit_flip_is_refused(void **state)
{
    (void)state;
    uint8_t *b;
    size_t size = small_table(&b);
    haptic_table_error err;
    for (size_t i = 0; i < size; i++)
        for (int bit = 0; bit < 8; bit++) {
            b[i] ^= (uint8_t)(1u << bit);
            if (validate_copy(b, size, &err) == 0)
                fail_msg("flip of byte %zu bit %d accepted", i, bit);
            b[i] ^= (uint8_t)(1u << bit);
        }
    free(b);
}

/* legal_lo..legal_hi: values that are valid for the field without changing
 * the layout (only the sample rate has such values). */
struct field {
    size_t offset, width;
    const char *name;
    uint64_t legal_lo, legal_hi;
};
static const struct field header_fields[] = {
    {8, 2, "format_major", 1, 0},        {12, 4, "header_size", 1, 0},    {20, 4, "sample_rate_hz", 1000, 768000},
    {24, 2, "channel_count", 1, 0},      {26, 2, "sample_format", 1, 0},  {28, 4, "focus_count", 1, 0},
    {32, 4, "samples_per_signal", 1, 0}, {36, 4, "reserved0", 1, 0},      {40, 8, "file_size", 1, 0},
    {48, 8, "channels_offset", 1, 0},    {56, 8, "foci_offset", 1, 0},    {64, 8, "gram_offset", 1, 0},
    {72, 8, "provenance_offset", 1, 0},  {80, 8, "payload_offset", 1, 0}, {88, 8, "payload_size", 1, 0},
};

static void put(uint8_t *p, size_t width, uint64_t v)
{
    for (size_t i = 0; i < width; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static void hostile_header_values_are_refused_by_the_field_check(void **state)
{
    (void)state;
    uint8_t *b;
    size_t size = small_table(&b);
    uint8_t *work = malloc(size);
    const uint64_t hostile[] = {0,
                                1,
                                0x7F,
                                0xFF,
                                0x7FFF,
                                0x8000,
                                0xFFFF,
                                0x7FFFFFFF,
                                0x80000000u,
                                0xFFFFFFFFu,
                                0x100000000ull,
                                0x7FFFFFFFFFFFFFFFull,
                                0x8000000000000000ull,
                                UINT64_MAX,
                                (uint64_t)-8,
                                (uint64_t)-64};
    haptic_table_error err;
    for (size_t f = 0; f < sizeof header_fields / sizeof *header_fields; f++)
        for (size_t h = 0; h < sizeof hostile / sizeof *hostile; h++) {
            memcpy(work, b, size);
            uint64_t v = hostile[h];
            if (header_fields[f].width < 8)
                v &= (1ull << (8 * header_fields[f].width)) - 1;
            put(work + header_fields[f].offset, header_fields[f].width, v);
            if (memcmp(work, b, size) == 0 || (v >= header_fields[f].legal_lo && v <= header_fields[f].legal_hi))
                continue; /* hostile value happens to be a valid one */
            table_fixture_fix_crc(work, size);
            int rc = validate_copy(work, size, &err);
            if (rc == 0)
                fail_msg("%s = 0x%llx accepted", header_fields[f].name, (unsigned long long)v);
            /* With a valid CRC, the refusal must come from a field or layout check. */
            assert_int_not_equal(rc, HAPTIC_TABLE_ECRC);
        }
    free(work);
    free(b);
}

static void sizes_whose_product_overflows_are_refused(void **state)
{
    (void)state;
    uint8_t *b;
    size_t size = small_table(&b);
    haptic_table_error err;
    /* Counts at their limits make a payload far beyond the file: the
     * product must be computed without wrapping and compared with the size. */
    put(b + 24, 2, 32);
    put(b + 28, 4, 1024);
    put(b + 32, 4, 1u << 22);
    put(b + 88, 8, (uint64_t)32 * 1024 * (1u << 22) * 2);
    table_fixture_fix_crc(b, size);
    int rc = validate_copy(b, size, &err);
    assert_true(rc == HAPTIC_TABLE_ELAYOUT);
    /* payload_size chosen so that offset + size wraps 2^64. */
    free(b);
    size = small_table(&b);
    put(b + 80, 8, UINT64_MAX - 63);
    table_fixture_fix_crc(b, size);
    assert_int_equal(validate_copy(b, size, &err), HAPTIC_TABLE_ELAYOUT);
    assert_non_null(strstr(err.message, "payload_offset"));
    free(b);
}

static void version_and_flags_are_checked(void **state)
{
    (void)state;
    uint8_t *b;
    size_t size = small_table(&b);
    haptic_table_error err;
    put(b + 8, 2, 2);
    table_fixture_fix_crc(b, size);
    assert_int_equal(validate_copy(b, size, &err), HAPTIC_TABLE_EVERSION);
    assert_non_null(strstr(err.message, "format_major"));
    put(b + 8, 2, 1);
    put(b + 10, 2, 4); /* a later minor version with the same layout is readable */
    table_fixture_fix_crc(b, size);
    assert_int_equal(validate_copy(b, size, &err), 0);
    put(b + 16, 4, 0x80010000u); /* in a later minor, an unknown optional flag is ignored */
    table_fixture_fix_crc(b, size);
    assert_int_equal(validate_copy(b, size, &err), 0);
    put(b + 16, 4, 0x00000001u); /* unknown required flag: refused */
    table_fixture_fix_crc(b, size);
    assert_int_equal(validate_copy(b, size, &err), HAPTIC_TABLE_EVERSION);
    memcpy(b, "HAPTBL\n\n", 8);
    assert_int_equal(validate_copy(b, size, &err), HAPTIC_TABLE_EMAGIC);
    free(b);
}

/* Record-level edits with a re-made CRC: the meaning checks must catch them. */
static void inconsistent_records_are_refused(void **state)
{
    (void)state;
    uint8_t *b;
    size_t size = small_table(&b);
    uint8_t *work = malloc(size);
    haptic_table t;
    assert_int_equal(haptic_table_validate(b, size, &t, NULL), 0);
    haptic_table_error err;
    const double nan = NAN, inf = INFINITY, neg = -1.0, big = 1e9, hot = 301.0, soft = 0.051;
    struct {
        uint64_t off;
        const void *val;
        size_t n;
        int want;
        const char *needle;
    } edits[] = {
        {t.channels_offset, &nan, 8, HAPTIC_TABLE_EFIELD, "channel 0 x_m"},
        {t.channels_offset + 24, &big, 8, HAPTIC_TABLE_EFIELD, "channel 1 y_m"},
        {t.foci_offset + 8, &inf, 8, HAPTIC_TABLE_EFIELD, "focus 0 x_m"},
        {t.foci_offset + 24, &neg, 8, HAPTIC_TABLE_EFIELD, "focus 0 scale_m"},
        {t.foci_offset + 48 + 32, &big, 8, HAPTIC_TABLE_EGRAM, "focus 1 energy"},
        {t.gram_offset + 8, &big, 8, HAPTIC_TABLE_EGRAM, "gram[1][0]"},
        {t.gram_offset + 16, &nan, 8, HAPTIC_TABLE_EGRAM, "gram[1][0]"},
        {t.foci_offset + 48, b + t.foci_offset, 4, HAPTIC_TABLE_EFIELD, "repeats"},
        {t.foci_offset + 4, "\x01", 1, HAPTIC_TABLE_EFIELD, "reserved"},
        {t.provenance_offset + 2, "\x07", 1, HAPTIC_TABLE_EFIELD, "control character"},
        {t.provenance_offset + 64 + 63, "x", 1, HAPTIC_TABLE_EFIELD, "after the terminator"},
        {t.panel_offset, &hot, 8, HAPTIC_TABLE_EFIELD, "panel temperature_c"},
        {t.panel_offset, &nan, 8, HAPTIC_TABLE_EFIELD, "panel temperature_c"},
        {t.panel_offset + 8, &soft, 8, HAPTIC_TABLE_EFIELD, "panel youngs_per_k"},
        {t.panel_offset + 8, &nan, 8, HAPTIC_TABLE_EFIELD, "panel youngs_per_k"},
        {t.panel_offset + 31, "\x01", 1, HAPTIC_TABLE_EFIELD, "panel reserved"},
        {116, "\x01", 1, HAPTIC_TABLE_EFIELD, "header reserved"},
    };
    for (size_t i = 0; i < sizeof edits / sizeof *edits; i++) {
        memcpy(work, b, size);
        memcpy(work + edits[i].off, edits[i].val, edits[i].n);
        table_fixture_fix_crc(work, size);
        int rc = validate_copy(work, size, &err);
        if (rc != edits[i].want || !strstr(err.message, edits[i].needle))
            fail_msg("edit %zu: rc %d (%s), want %d with '%s'", i, rc, err.message, edits[i].want, edits[i].needle);
    }
    free(work);
    free(b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(every_truncation_is_refused),
        cmocka_unit_test(every_single_bit_flip_is_refused),
        cmocka_unit_test(hostile_header_values_are_refused_by_the_field_check),
        cmocka_unit_test(sizes_whose_product_overflows_are_refused),
        cmocka_unit_test(version_and_flags_are_checked),
        cmocka_unit_test(inconsistent_records_are_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
