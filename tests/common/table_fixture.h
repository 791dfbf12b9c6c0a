/* Known-signal tables for the tests (and the fuzz seed corpus). */
#ifndef TABLE_FIXTURE_H
#define TABLE_FIXTURE_H
#include <haptic_table.h>
#include <stdint.h>

typedef struct table_fixture {
    haptic_table_spec spec;
    double channel_xy[HAPTIC_TABLE_MAX_CHANNELS * 2];
    uint32_t ids[64];
    double focus_xy[128];
    double scale[64];
    double lead_s[64];
    haptic_panel panel;
    haptic_gain_range gain_range[64];
    haptic_range_spec range;
    int16_t *samples;
} table_fixture;

/* Deterministic signals (a 32-bit LCG) with the extremes -32768 and 32767
 * present; focus ids 10, 20, 30, ... ; foci <= 64. A 1.3 table with the
 * playback section: exciter drive, 2.5 N at full scale, focus f's lead time
 * (f mod 4 + 1) / 4 of the signal; and the panel section: calibrated at
 * 23 C, dE/E/dT -0.4 %/K. Set spec.drive_kind = HAPTIC_DRIVE_UNKNOWN or
 * spec.panel = NULL to leave a section out. The range section is filled in
 * `range` but left out: spec.range = &fx->range adds it (threshold 1 um,
 * whole area; focus f safe from 0.5 / (f + 1) to 2 (f + 1), the last focus
 * to +infinity). */
void table_fixture_init(table_fixture *fx, uint16_t channels, uint32_t foci, uint32_t samples, uint32_t seed);
void table_fixture_free(table_fixture *fx);
/* Encode into a new malloc'ed buffer; returns its size (0 on failure). */
size_t table_fixture_encode(const table_fixture *fx, uint8_t **out);
/* Recompute and store the CRC-32 trailer after a deliberate edit. */
void table_fixture_fix_crc(uint8_t *buf, size_t size);
#endif
