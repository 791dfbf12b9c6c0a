/* haptic_table.h - the calibration table format shared by calibgen (writer)
 * and hapticd (reader). One source of truth: docs/table-format.md documents
 * exactly what this code reads and writes. Three libraries: the reader
 * (validate, open, accessors), the summary (print_summary) and the writer
 * (encode, write); the device links only the first two.
 *
 * Conventions: functions return 0 on success or a negative HAPTIC_TABLE_E*
 * code; the optional haptic_table_error receives a one-line message that
 * names the field and its byte offset.
 *
 * The reader never allocates beyond the single file buffer, validates every
 * field against the file length before touching it, and refuses (never
 * half-uses) a truncated, corrupted, oversized or wrong-version table.
 */
#ifndef HAPTIC_TABLE_H
#define HAPTIC_TABLE_H

#include <stddef.h>
#include <stdio.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "haptic_table: the payload is accessed in place and is little-endian; big-endian hosts are not supported"
#endif

#define HAPTIC_TABLE_MAGIC "HAPTBL\r\n" /* 8 bytes, no terminator */
#define HAPTIC_TABLE_VERSION_MAJOR 1u
#define HAPTIC_TABLE_VERSION_MINOR 3u /* newest minor this code writes and fully checks */
#define HAPTIC_TABLE_HEADER_SIZE 128u
#define HAPTIC_TABLE_CHANNEL_RECORD_SIZE 16u
#define HAPTIC_TABLE_FOCUS_RECORD_SIZE 48u
#define HAPTIC_TABLE_PROVENANCE_SIZE 256u
#define HAPTIC_TABLE_PANEL_SIZE 32u
#define HAPTIC_TABLE_PAYLOAD_ALIGN 64u
#define HAPTIC_TABLE_CRC_SIZE 4u

/* Limits a reader enforces; a writer refuses to exceed them too. */
#define HAPTIC_TABLE_MAX_CHANNELS 32u
#define HAPTIC_TABLE_MAX_FOCI 1024u
#define HAPTIC_TABLE_MAX_SAMPLES (1u << 22) /* per signal: 87 s at 48 kHz */
#define HAPTIC_TABLE_MIN_RATE_HZ 1000u
#define HAPTIC_TABLE_MAX_RATE_HZ 768000u
#define HAPTIC_TABLE_MAX_FILE_SIZE ((uint64_t)1 << 31) /* 2 GiB */

/* Optional flag (1.1): the playback section is present (its offset at header byte 96). */
#define HAPTIC_TABLE_FLAG_PLAYBACK 0x00010000u
/* Optional flag (1.2): the panel section is present (its offset at header byte 104). */
#define HAPTIC_TABLE_FLAG_PANEL 0x00020000u
/* Optional flag (1.3): the range section is present (its offset at header byte 112). */
#define HAPTIC_TABLE_FLAG_RANGE 0x00040000u

/* The range section's limits (a reader refuses values outside them). */
#define HAPTIC_TABLE_RANGE_MAX_GAIN 1e6 /* lo <= this; hi <= this or +infinity */

/* The panel section's ranges (a reader refuses values outside them). */
#define HAPTIC_TABLE_PANEL_MIN_TEMPERATURE_C (-100.0)
#define HAPTIC_TABLE_PANEL_MAX_TEMPERATURE_C 300.0
#define HAPTIC_TABLE_PANEL_MAX_YOUNGS_PER_K 0.05 /* |dE/E/dT|, 1/K: 5 %/K, ten times a polymer's */

/* The off-diagonal Gram elements are checked against the payload when the
 * products this takes, K (K - 1) / 2 * N * C, are at most this many: 169 foci
 * of 8 channels x 37,800 frames, about 0.7 s on a desktop core
 * (docs/table-format.md, "Gram matrix"; docs/BENCHMARKS.md). */
#define HAPTIC_TABLE_GRAM_FULL_CHECK_MAX_PRODUCTS ((uint64_t)1 << 32)

/* Provenance text fields: NUL-padded UTF-8, fixed width. */
#define HAPTIC_TABLE_SCENE_NAME_LEN 64u
#define HAPTIC_TABLE_SCENE_HASH_LEN 64u
#define HAPTIC_TABLE_TOOL_VERSION_LEN 64u
#define HAPTIC_TABLE_CREATED_LEN 64u

enum haptic_sample_format {
    HAPTIC_SAMPLE_S16LE = 1, /* signed 16-bit, full scale = 32767 (-32768 allowed) */
};

/* What a sample means physically (1.1 playback section). With
 * F = s * force_full_scale_n / 32767 for a stored sample s played at gain 1: */
enum haptic_drive_kind {
    HAPTIC_DRIVE_UNKNOWN = 0,                /* a 1.0 table, or no playback section */
    HAPTIC_DRIVE_FORCE = 1,                  /* F is the force on the plate at the exciter's position */
    HAPTIC_DRIVE_EXCITER = 2,                /* F is the exciter's motor force Bl i; the plate gets it
                                                filtered by the exciter's own response */
    HAPTIC_DRIVE_EXCITER_PRECOMPENSATED = 3, /* as EXCITER, pre-filtered by the inverse of that response
                                                so the plate receives the time-reversal force */
};

enum haptic_table_status {
    HAPTIC_TABLE_OK = 0,
    HAPTIC_TABLE_EIO = -1,      /* open/read/write/rename failed (errno in message) */
    HAPTIC_TABLE_ENOMEM = -2,   /* the single file buffer could not be allocated */
    HAPTIC_TABLE_ETRUNC = -3,   /* file shorter than its header or sections say */
    HAPTIC_TABLE_EMAGIC = -4,   /* not a haptic table */
    HAPTIC_TABLE_EVERSION = -5, /* format version this reader cannot read */
    HAPTIC_TABLE_EFIELD = -6,   /* a header or record field out of its allowed range */
    HAPTIC_TABLE_ELAYOUT = -7,  /* section offsets/sizes inconsistent */
    HAPTIC_TABLE_ECRC = -8,     /* CRC-32 mismatch */
    HAPTIC_TABLE_EGRAM = -9,    /* Gram matrix inconsistent (asymmetric, non-finite, energy) */
    HAPTIC_TABLE_EINVAL = -10,  /* bad argument to the API (writer spec, NULL pointer) */
    HAPTIC_TABLE_ETOOBIG = -11, /* file larger than HAPTIC_TABLE_MAX_FILE_SIZE */
};

typedef struct haptic_table_error {
    int code;          /* enum haptic_table_status */
    uint64_t offset;   /* byte offset the message refers to (0 if none) */
    char message[200]; /* one line, no trailing newline */
} haptic_table_error;

typedef struct haptic_focus_info {
    uint32_t id;        /* user-visible focus id (scene order, not necessarily 0..K-1) */
    double x_m, y_m;    /* focus position on the plate, metres, plate origin at a corner */
    double scale_m;     /* focal peak |displacement| (m) predicted when the stored samples play at gain 1 */
    double energy;      /* sum over channels and samples of s^2 (s in counts) = Gram[f][f] */
    double lead_time_s; /* playback start (frame 0) to the focal peak, s; NaN if unknown */
} haptic_focus_info;

typedef struct haptic_provenance {
    char scene_name[HAPTIC_TABLE_SCENE_NAME_LEN + 1];
    char scene_hash[HAPTIC_TABLE_SCENE_HASH_LEN + 1];
    char tool_version[HAPTIC_TABLE_TOOL_VERSION_LEN + 1];
    char created_utc[HAPTIC_TABLE_CREATED_LEN + 1];
} haptic_provenance;

/* A validated table: a view into one buffer. Treat the fields as read-only. */
typedef struct haptic_table {
    const uint8_t *data; /* whole file */
    size_t size;
    void *owned; /* buffer to free on close (NULL for a caller's buffer) */
    uint16_t format_minor;
    uint32_t flags;
    uint32_t sample_rate_hz;
    uint16_t channel_count;
    uint16_t sample_format;
    uint32_t focus_count;
    uint32_t samples_per_signal;
    uint64_t channels_offset, foci_offset, gram_offset, provenance_offset, payload_offset;
    uint64_t playback_offset; /* 0 without a playback section */
    uint32_t crc32;
    double force_full_scale_n; /* force (N) of sample 32767 at gain 1; NaN if unknown */
    uint16_t drive_kind;       /* enum haptic_drive_kind */
    uint64_t panel_offset;     /* 0 without a panel section */
    uint64_t range_offset;     /* 0 without a range section */
} haptic_table;

/* The plate the drives were calibrated for (1.2 panel section): what a
 * device needs to play them on a panel at another temperature
 * (haptic_stretch.h): the speed ratio at temperature T is
 * sqrt(1 + youngs_per_k (T - temperature_c)). */
typedef struct haptic_panel {
    double temperature_c; /* the plate's temperature in the calibration, degrees Celsius */
    double youngs_per_k;  /* the plate's relative change of Young's modulus per kelvin (dE/E/dT, 1/K) */
} haptic_panel;

/* Where the verdict behind a range section looked (1.3). */
enum haptic_range_scope {
    HAPTIC_RANGE_WHOLE_AREA = 1, /* every point of the active area farther than lambda/2 from the focus */
    HAPTIC_RANGE_FOCI_ONLY = 2,  /* only the other foci farther than lambda/2 (no area was measured) */
};

/* The safe range of one focus (1.3 range section): the gains, applied to the
 * stored samples (1 = as stored), over which the focus passes the verdict.
 * lo: the gain at which the focal peak just reaches the threshold
 * (threshold / peak); hi: the gain at which the first point beyond lambda/2
 * reaches it (threshold / the largest |w| there, at any time); +infinity when
 * nothing beyond lambda/2 moves. The focus passes at gain g when
 * lo <= g < hi; lo >= hi means no gain passes (a failing focus). */
typedef struct haptic_gain_range {
    double lo, hi;
} haptic_gain_range;

/* The one clamp rule for a safe range (hapticd plays it; one home so a tool
 * can judge exactly what plays): min(max(gain, lo), top), the top
 * hi (1 - HAPTIC_GAIN_RANGE_TOP_MARGIN) and below hi in any case, so the gain
 * applied after Q30 rounding (2^-31 at most) stays below hi for every top
 * above 5e-4 (-66 dB). When lo >= hi (no gain passes) the result is the top:
 * safety wins, a focus that cannot be felt rather than a ghost. So
 * haptic_gain_range_clamp(r, 0) is the bottom as played: lo, or the top when
 * lo >= hi. An infinite hi clamps from below only. Pure, real-time safe. */
#define HAPTIC_GAIN_RANGE_TOP_MARGIN 1e-6
double haptic_gain_range_clamp(const haptic_gain_range *r, double gain);
/* Foci played together (one gain for all): the intersection of their
 * ranges, the largest lo and the smallest hi, into *acc. */
void haptic_gain_range_intersect(haptic_gain_range *acc, const haptic_gain_range *r);

/* Writer input for the range section (1.3). */
typedef struct haptic_range_spec {
    double threshold_m;             /* the verdict's threshold (m), finite, 0 < t <= 1000 */
    uint16_t scope;                 /* enum haptic_range_scope */
    const haptic_gain_range *focus; /* [focus_count], in the order of the foci */
} haptic_range_spec;

/* Writer input. The writer computes the Gram matrix and energies itself. */
typedef struct haptic_table_spec {
    uint32_t sample_rate_hz;
    uint16_t channel_count;
    uint32_t focus_count;
    uint32_t samples_per_signal;
    const double *channel_xy_m;  /* [channel_count][2] exciter positions */
    const uint32_t *focus_id;    /* [focus_count] */
    const double *focus_xy_m;    /* [focus_count][2] */
    const double *focus_scale_m; /* [focus_count] */
    const int16_t *samples;      /* [focus][sample][channel], i.e. interleaved frames */
    const char *scene_name, *scene_hash, *tool_version, *created_utc; /* may be NULL (empty) */
    /* Playback section (1.1), written when drive_kind != HAPTIC_DRIVE_UNKNOWN;
     * then force_full_scale_n and focus_lead_time_s are required. */
    uint16_t drive_kind;             /* enum haptic_drive_kind */
    double force_full_scale_n;       /* N at sample 32767, gain 1 */
    const double *focus_lead_time_s; /* [focus_count] playback start to focal peak, s */
    /* Panel section (1.2), written when given (NULL: none). */
    const haptic_panel *panel;
    /* Range section (1.3), written when given (NULL: none). */
    const haptic_range_spec *range;
} haptic_table_spec;

/* Human-readable name of a status code (never NULL). */
const char *haptic_table_error_string(int code);
/* Name of an enum haptic_drive_kind value (never NULL). */
const char *haptic_drive_kind_name(int kind);

/* Validate a table held in memory (the caller keeps the buffer alive; it must
 * be at least 2-byte aligned, as malloc's is: the payload is used in place). */
int haptic_table_validate(const void *data, size_t size, haptic_table *out, haptic_table_error *err);

/* Read a file into one buffer and validate it; on failure nothing is kept. */
int haptic_table_open(const char *path, haptic_table *out, haptic_table_error *err);

/* Free the buffer owned by a table from haptic_table_open (safe on a zeroed table). */
void haptic_table_close(haptic_table *t);

/* Accessors (the table must be validated; indices are checked, out of range returns error/NULL). */
int haptic_table_focus(const haptic_table *t, uint32_t index, haptic_focus_info *out);
int haptic_table_channel_position(const haptic_table *t, uint32_t channel, double *x_m, double *y_m);
double haptic_table_gram(const haptic_table *t, uint32_t i, uint32_t j); /* NaN if out of range */
/* The Gram matrix of K signals of n int16 samples each (signal f at
 * signals + f n) into gram[K][K], row-major: exact integer inner products
 * rounded once to double, as a table's own (for drives derived from a
 * table, e.g. stretched: haptic_stretch.h). K (K + 1) / 2 n products. */
void haptic_table_gram_of(const int16_t *signals, uint32_t K, uint64_t n, double *gram);
const int16_t *haptic_table_signal(const haptic_table *t, uint32_t focus); /* [n][c] interleaved */
void haptic_table_provenance(const haptic_table *t, haptic_provenance *out);
/* Table-level playback facts (1.1): NaN / HAPTIC_DRIVE_UNKNOWN for a 1.0 table. */
double haptic_table_force_full_scale_n(const haptic_table *t);
int haptic_table_drive_kind(const haptic_table *t);
/* The panel section (1.2): 0 and *out filled, or -1 when the table has none. */
int haptic_table_panel(const haptic_table *t, haptic_panel *out);
/* The range section (1.3): 0 and the focus's safe range in *out, or -1 when
 * the table has none (or index is out of range). */
int haptic_table_gain_range(const haptic_table *t, uint32_t index, haptic_gain_range *out);
/* The range section's threshold (m) and scope (enum haptic_range_scope):
 * NaN and 0 when the table has none. */
double haptic_table_range_threshold_m(const haptic_table *t);
int haptic_table_range_scope(const haptic_table *t);
/* Playback start to the focal peak of focus `index` (s); NaN if unknown or out of range. */
double haptic_table_lead_time_s(const haptic_table *t, uint32_t index);
/* Index of the focus with this id (any u32, 0 and 0xFFFFFFFF included), or -1. */
int32_t haptic_table_find_focus(const haptic_table *t, uint32_t id);

/* Encoded size of a spec (0 if the spec is invalid or too large). */
uint64_t haptic_table_encoded_size(const haptic_table_spec *spec);
/* Encode into a caller buffer of at least haptic_table_encoded_size() bytes. */
int haptic_table_encode(const haptic_table_spec *spec, void *buf, size_t size, haptic_table_error *err);
/* Encode and write atomically: temp file in the same directory, fsync, rename. */
int haptic_table_write(const char *path, const haptic_table_spec *spec, haptic_table_error *err);

/* Multi-line human summary (used by `calibgen inspect` and `hapticd --check`). */
int haptic_table_print_summary(const haptic_table *t, const char *path, FILE *out);

#ifdef __cplusplus
}
#endif
#endif /* HAPTIC_TABLE_H */
