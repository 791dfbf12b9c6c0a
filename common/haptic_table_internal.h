/* haptic_table_internal.h - byte layout shared by the reader, the writer and
 * the summary (docs/table-format.md; keep both in step). Not installed, not
 * part of the API. */
#ifndef HAPTIC_TABLE_INTERNAL_H
#define HAPTIC_TABLE_INTERNAL_H

#include "haptic_table.h"

#include <stdbool.h>
#include <stdint.h>
#include <string.h>

/* Header field offsets (docs/table-format.md, "Header"). */
enum {
    OFF_MAGIC = 0,
    OFF_VERSION_MAJOR = 8,
    OFF_VERSION_MINOR = 10,
    OFF_HEADER_SIZE = 12,
    OFF_FLAGS = 16,
    OFF_SAMPLE_RATE = 20,
    OFF_CHANNEL_COUNT = 24,
    OFF_SAMPLE_FORMAT = 26,
    OFF_FOCUS_COUNT = 28,
    OFF_SAMPLES = 32,
    OFF_RESERVED0 = 36,
    OFF_FILE_SIZE = 40,
    OFF_CHANNELS_OFFSET = 48,
    OFF_FOCI_OFFSET = 56,
    OFF_GRAM_OFFSET = 64,
    OFF_PROVENANCE_OFFSET = 72,
    OFF_PAYLOAD_OFFSET = 80,
    OFF_PAYLOAD_SIZE = 88,
    OFF_PLAYBACK_OFFSET = 96,  /* 1.1; reserved (zero) in 1.0 */
    OFF_PANEL_OFFSET = 104,    /* 1.2; reserved (zero) before */
    OFF_RANGE_OFFSET = 112,    /* 1.3; reserved (zero) before */
    OFF_HEADER_RESERVED = 120, /* to 128: zero up to the newest minor this reader knows */
};

/* Focus record field offsets. */
enum { FOC_ID = 0, FOC_RESERVED = 4, FOC_X = 8, FOC_Y = 16, FOC_SCALE = 24, FOC_ENERGY = 32, FOC_RESERVED2 = 40 };
/* Provenance field offsets. */
enum { PROV_SCENE_NAME = 0, PROV_SCENE_HASH = 64, PROV_TOOL_VERSION = 128, PROV_CREATED = 192 };
/* Playback section (1.1) field offsets; lead times follow, one f64 per focus. */
enum { PLAY_FORCE = 0, PLAY_DRIVE_KIND = 8, PLAY_RESERVED = 10, PLAY_LEAD_TIMES = 16 };
/* Panel section (1.2) field offsets; reserved (zero) to HAPTIC_TABLE_PANEL_SIZE. */
enum { PANEL_TEMPERATURE = 0, PANEL_YOUNGS_PER_K = 8, PANEL_RESERVED = 16 };
/* Range section (1.3) field offsets; gain_lo, gain_hi follow, two f64 per focus. */
enum { RANGE_THRESHOLD = 0, RANGE_SCOPE = 8, RANGE_RESERVED = 10, RANGE_GAINS = 16 };

/* Flags: the low 16 bits are "required" (a reader that does not know a set
 * bit must refuse the file), the high 16 bits "optional" (ignored if unknown
 * in a file of a later minor version). */
#define FLAGS_REQUIRED_MASK 0x0000FFFFu
#define FLAGS_KNOWN_REQUIRED 0x00000000u

/* Bound of the lead time past the last frame: the focus can still form while
 * the last-played (earliest-arriving, direct) paths travel to it, a fraction
 * of a plate crossing; one second is far above any plate the format holds. */
#define LEAD_TIME_SLACK_S 1.0
#define FORCE_FULL_SCALE_MAX_N 1e6

static inline uint16_t rd16(const uint8_t *p) { return (uint16_t)(p[0] | (p[1] << 8)); }
static inline uint32_t rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static inline uint64_t rd64(const uint8_t *p) { return (uint64_t)rd32(p) | ((uint64_t)rd32(p + 4) << 32); }
static inline double rdf64(const uint8_t *p)
{
    uint64_t u = rd64(p);
    double d;
    memcpy(&d, &u, sizeof d);
    return d;
}
static inline void wr16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}
static inline void wr32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}
static inline void wr64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}
static inline void wrf64(uint8_t *p, double d)
{
    uint64_t u;
    memcpy(&u, &d, sizeof u);
    wr64(p, u);
}

static inline uint64_t align_up(uint64_t v, uint64_t a) { return (v + a - 1) / a * a; }

/* Section sizes and the writer's placement for given counts; all counts are
 * range-checked first, so the products stay far below 2^63 (max payload
 * 1024 * 2^22 * 32 * 2 = 2^38). */
struct layout {
    uint64_t channels_offset, channels_size;
    uint64_t foci_offset, foci_size;
    uint64_t gram_offset, gram_size;
    uint64_t provenance_offset, provenance_size;
    uint64_t playback_offset, playback_size; /* 0, 0 without the section */
    uint64_t panel_offset, panel_size;       /* 0, 0 without the section */
    uint64_t range_offset, range_size;       /* 0, 0 without the section */
    uint64_t payload_offset, payload_size;
    uint64_t file_size;
};

static inline uint64_t playback_section_size(uint32_t foci) { return PLAY_LEAD_TIMES + (uint64_t)foci * 8; }
static inline uint64_t range_section_size(uint32_t foci) { return RANGE_GAINS + (uint64_t)foci * 16; }

static inline void canonical_layout(uint32_t channels, uint32_t foci, uint32_t samples, bool playback, bool panel,
                                    bool range, struct layout *l)
{
    l->channels_size = (uint64_t)channels * HAPTIC_TABLE_CHANNEL_RECORD_SIZE;
    l->foci_size = (uint64_t)foci * HAPTIC_TABLE_FOCUS_RECORD_SIZE;
    l->gram_size = (uint64_t)foci * foci * sizeof(double);
    l->provenance_size = HAPTIC_TABLE_PROVENANCE_SIZE;
    l->playback_size = playback ? playback_section_size(foci) : 0;
    l->panel_size = panel ? HAPTIC_TABLE_PANEL_SIZE : 0;
    l->range_size = range ? range_section_size(foci) : 0;
    l->payload_size = (uint64_t)foci * samples * channels * sizeof(int16_t);
    l->channels_offset = HAPTIC_TABLE_HEADER_SIZE;
    l->foci_offset = align_up(l->channels_offset + l->channels_size, 8);
    l->gram_offset = align_up(l->foci_offset + l->foci_size, 8);
    l->provenance_offset = align_up(l->gram_offset + l->gram_size, 8);
    uint64_t end = l->provenance_offset + l->provenance_size;
    l->playback_offset = playback ? align_up(end, 8) : 0;
    if (playback)
        end = l->playback_offset + l->playback_size;
    l->panel_offset = panel ? align_up(end, 8) : 0;
    if (panel)
        end = l->panel_offset + l->panel_size;
    l->range_offset = range ? align_up(end, 8) : 0;
    if (range)
        end = l->range_offset + l->range_size;
    l->payload_offset = align_up(end, HAPTIC_TABLE_PAYLOAD_ALIGN);
    l->file_size = l->payload_offset + l->payload_size + HAPTIC_TABLE_CRC_SIZE;
}

/* Fills *err (if any) and returns code. */
__attribute__((format(printf, 4, 5))) int haptic_table_fail_(haptic_table_error *err, int code, uint64_t offset,
                                                             const char *fmt, ...);

/* Exact inner product of two int16 sequences of length n <= 2^27: each product
 * is at most 2^30 in magnitude, so the sum stays below 2^57 and int64 holds it
 * without rounding. The writer and the reader compute the Gram matrix with this
 * one function (haptic_table_gram.c, built with the vectoriser on). */
int64_t haptic_table_dot_(const int16_t *a, const int16_t *b, uint64_t n);

/* Meaning checks after the CRC (haptic_table_content.c): records, playback,
 * panel and range sections, Gram matrix, provenance, reserved bytes and
 * gaps, payload against the Gram matrix. `t` holds the validated header and section offsets. */
int haptic_table_check_content_(const uint8_t *b, const haptic_table *t, haptic_table_error *err);

#endif /* HAPTIC_TABLE_INTERNAL_H */
