/* Tables and boards for the hapticd tests, built with the common/ writer. */
#ifndef FW_FIXTURE_H
#define FW_FIXTURE_H

#include "board.h"

#include <haptic_table.h>
#include <stddef.h>
#include <stdint.h>

enum fw_kind {
    FW_RANDOM,   /* independent uniform samples in [-amp, amp] (deterministic LCG) */
    FW_DISJOINT, /* focus f is +-amp in its own time slot, 0 elsewhere: equal energies, Gram off-diagonal 0 */
    FW_CONSTANT, /* every sample = amp (maximally correlated foci) */
};

struct fw_table {
    uint16_t channels;
    uint32_t foci, samples;
    double *channel_xy, *focus_xy, *scale;
    uint32_t *ids;                  /* ids[f] = 1000 - 10 f: not sorted, not contiguous */
    int16_t *samples_buf;           /* [focus][n][c] */
    const haptic_panel *panel;      /* the panel section fw_table_encode writes (NULL: none) */
    const haptic_range_spec *range; /* the range section fw_table_encode writes (NULL: none) */
    uint8_t *buf;                   /* encoded file */
    size_t size;
    haptic_table table; /* validated view of buf */
};

void fw_table_make(struct fw_table *t, uint16_t channels, uint32_t foci, uint32_t samples, enum fw_kind kind, int amp,
                   uint32_t seed);
/* Encode again, with a playback section (format 1.1) giving each focus's lead
 * time when lead_time_s is not NULL, without one (as a 1.0 writer) when NULL. */
void fw_table_encode(struct fw_table *t, const double *lead_time_s);
void fw_table_free(struct fw_table *t);
/* Write the encoded bytes to path (plain write, for tests). */
void fw_table_write(const struct fw_table *t, const char *path);
/* Replace the file at path with `text` at once (written beside it, then
 * renamed over it): a reader sees the old file or the new one, never half. */
void fw_write_text(const char *path, const char *text);
static inline int16_t fw_sample(const struct fw_table *t, uint32_t f, uint32_t n, uint32_t c)
{
    return t->samples_buf[((size_t)f * t->samples + n) * t->channels + c];
}

/* Defaults with channels = map_count = table channels, rate 48 kHz. */
void fw_board(struct hd_board *b, unsigned channels, enum hd_sample_format fmt, unsigned period);

#endif
