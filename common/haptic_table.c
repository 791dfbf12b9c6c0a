/* haptic_table.c - reader, validator and atomic writer of the calibration
 * table. Field layout: docs/table-format.md (keep both in step). */
#define _POSIX_C_SOURCE 200809L
#include "haptic_table.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

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
};

/* Focus record field offsets. */
enum { FOC_ID = 0, FOC_RESERVED = 4, FOC_X = 8, FOC_Y = 16, FOC_SCALE = 24, FOC_ENERGY = 32, FOC_RESERVED2 = 40 };
/* Provenance field offsets. */
enum { PROV_SCENE_NAME = 0, PROV_SCENE_HASH = 64, PROV_TOOL_VERSION = 128, PROV_CREATED = 192 };

/* Flags: the low 16 bits are "required" (a reader that does not know a set
 * bit must refuse the file), the high 16 bits "optional" (ignored if unknown).
 * Version 1.0 defines none. */
#define FLAGS_REQUIRED_MASK 0x0000FFFFu
#define FLAGS_KNOWN_REQUIRED 0x00000000u

static uint16_t rd16(const uint8_t *p) { return (uint16_t)(p[0] | (p[1] << 8)); }
static uint32_t rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static uint64_t rd64(const uint8_t *p) { return (uint64_t)rd32(p) | ((uint64_t)rd32(p + 4) << 32); }
static double rdf64(const uint8_t *p)
{
    uint64_t u = rd64(p);
    double d;
    memcpy(&d, &u, sizeof d);
    return d;
}
static void wr16(uint8_t *p, uint16_t v) { p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); }
static void wr32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}
static void wr64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}
static void wrf64(uint8_t *p, double d)
{
    uint64_t u;
    memcpy(&u, &d, sizeof u);
    wr64(p, u);
}

static uint64_t align_up(uint64_t v, uint64_t a) { return (v + a - 1) / a * a; }

__attribute__((format(printf, 4, 5))) static int fail(haptic_table_error *err, int code, uint64_t offset,
                                                      const char *fmt, ...)
{
    if (err) {
        err->code = code;
        err->offset = offset;
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
    }
    return code;
}

const char *haptic_table_error_string(int code)
{
    switch (code) {
    case HAPTIC_TABLE_OK: return "ok";
    case HAPTIC_TABLE_EIO: return "I/O error";
    case HAPTIC_TABLE_ENOMEM: return "out of memory";
    case HAPTIC_TABLE_ETRUNC: return "truncated table";
    case HAPTIC_TABLE_EMAGIC: return "not a haptic table (bad magic)";
    case HAPTIC_TABLE_EVERSION: return "unsupported table format version";
    case HAPTIC_TABLE_EFIELD: return "field out of range";
    case HAPTIC_TABLE_ELAYOUT: return "inconsistent section layout";
    case HAPTIC_TABLE_ECRC: return "CRC-32 mismatch (corrupted table)";
    case HAPTIC_TABLE_EGRAM: return "inconsistent Gram matrix";
    case HAPTIC_TABLE_EINVAL: return "invalid argument";
    case HAPTIC_TABLE_ETOOBIG: return "table too large";
    default: return "unknown error";
    }
}

/* Section sizes for given counts; all counts are already range-checked, so
 * the products stay far below 2^63 (max payload 1024 * 2^22 * 32 * 2 = 2^38). */
struct layout {
    uint64_t channels_offset, channels_size;
    uint64_t foci_offset, foci_size;
    uint64_t gram_offset, gram_size;
    uint64_t provenance_offset, provenance_size;
    uint64_t payload_offset, payload_size;
    uint64_t file_size;
};

static void canonical_layout(uint32_t channels, uint32_t foci, uint32_t samples, struct layout *l)
{
    l->channels_size = (uint64_t)channels * HAPTIC_TABLE_CHANNEL_RECORD_SIZE;
    l->foci_size = (uint64_t)foci * HAPTIC_TABLE_FOCUS_RECORD_SIZE;
    l->gram_size = (uint64_t)foci * foci * sizeof(double);
    l->provenance_size = HAPTIC_TABLE_PROVENANCE_SIZE;
    l->payload_size = (uint64_t)foci * samples * channels * sizeof(int16_t);
    l->channels_offset = HAPTIC_TABLE_HEADER_SIZE;
    l->foci_offset = align_up(l->channels_offset + l->channels_size, 8);
    l->gram_offset = align_up(l->foci_offset + l->foci_size, 8);
    l->provenance_offset = align_up(l->gram_offset + l->gram_size, 8);
    l->payload_offset = align_up(l->provenance_offset + l->provenance_size, HAPTIC_TABLE_PAYLOAD_ALIGN);
    l->file_size = l->payload_offset + l->payload_size + HAPTIC_TABLE_CRC_SIZE;
}

static int check_range_u32(haptic_table_error *err, uint64_t off, const char *field, uint32_t v, uint32_t lo,
                           uint32_t hi)
{
    if (v < lo || v > hi)
        return fail(err, HAPTIC_TABLE_EFIELD, off, "offset %llu (%s): %lu is outside %lu..%lu",
                    (unsigned long long)off, field, (unsigned long)v, (unsigned long)lo, (unsigned long)hi);
    return 0;
}

/* A section [off, off+size) must start at or after `floor`, be aligned and end
 * before the CRC trailer. */
static int check_section(haptic_table_error *err, uint64_t field_off, const char *name, uint64_t off, uint64_t size,
                         uint64_t floor, uint64_t align, uint64_t limit)
{
    if (off % align != 0)
        return fail(err, HAPTIC_TABLE_ELAYOUT, field_off, "offset %llu (%s): %llu is not a multiple of %llu",
                    (unsigned long long)field_off, name, (unsigned long long)off, (unsigned long long)align);
    if (off < floor || off > limit || size > limit - off)
        return fail(err, HAPTIC_TABLE_ELAYOUT, field_off,
                    "offset %llu (%s): section [%llu, +%llu) overlaps a previous section or the end (%llu)",
                    (unsigned long long)field_off, name, (unsigned long long)off, (unsigned long long)size,
                    (unsigned long long)limit);
    return 0;
}

static int check_text(haptic_table_error *err, const uint8_t *p, uint64_t off, size_t len, const char *name)
{
    bool ended = false;
    for (size_t i = 0; i < len; i++) {
        if (ended && p[i] != 0)
            return fail(err, HAPTIC_TABLE_EFIELD, off + i, "offset %llu (provenance %s): bytes after the terminator",
                        (unsigned long long)(off + i), name);
        if (p[i] == 0)
            ended = true;
        else if (p[i] < 0x20 || p[i] == 0x7f)
            return fail(err, HAPTIC_TABLE_EFIELD, off + i, "offset %llu (provenance %s): control character 0x%02x",
                        (unsigned long long)(off + i), name, p[i]);
    }
    return 0;
}

int haptic_table_validate(const void *data, size_t size, haptic_table *out, haptic_table_error *err)
{
    if (err) {
        err->code = 0;
        err->offset = 0;
        err->message[0] = '\0';
    }
    if (!data || !out)
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "NULL table buffer");
    const uint8_t *b = data;
    haptic_table t;
    memset(&t, 0, sizeof t);

    if (size < 12)
        return fail(err, HAPTIC_TABLE_ETRUNC, size, "offset %zu: file of %zu bytes ends inside the header", size, size);
    if (memcmp(b + OFF_MAGIC, HAPTIC_TABLE_MAGIC, 8) != 0)
        return fail(err, HAPTIC_TABLE_EMAGIC, 0, "offset 0 (magic): not a haptic table");
    uint16_t major = rd16(b + OFF_VERSION_MAJOR);
    if (major != HAPTIC_TABLE_VERSION_MAJOR)
        return fail(err, HAPTIC_TABLE_EVERSION, OFF_VERSION_MAJOR,
                    "offset %d (format_major): version %u, this reader reads version %u", OFF_VERSION_MAJOR,
                    (unsigned)major, HAPTIC_TABLE_VERSION_MAJOR);
    t.format_minor = rd16(b + OFF_VERSION_MINOR);
    if (size < HAPTIC_TABLE_HEADER_SIZE)
        return fail(err, HAPTIC_TABLE_ETRUNC, size, "offset %zu: file of %zu bytes ends inside the header", size, size);
    uint32_t header_size = rd32(b + OFF_HEADER_SIZE);
    if (header_size < HAPTIC_TABLE_HEADER_SIZE || header_size > 4096 || header_size % 8 != 0)
        return fail(err, HAPTIC_TABLE_EFIELD, OFF_HEADER_SIZE,
                    "offset %d (header_size): %lu, expected a multiple of 8 in %u..4096", OFF_HEADER_SIZE,
                    (unsigned long)header_size, HAPTIC_TABLE_HEADER_SIZE);
    if (t.format_minor == 0 && header_size != HAPTIC_TABLE_HEADER_SIZE)
        return fail(err, HAPTIC_TABLE_EFIELD, OFF_HEADER_SIZE, "offset %d (header_size): %lu, version 1.0 has %u",
                    OFF_HEADER_SIZE, (unsigned long)header_size, HAPTIC_TABLE_HEADER_SIZE);
    t.flags = rd32(b + OFF_FLAGS);
    if ((t.flags & FLAGS_REQUIRED_MASK & ~FLAGS_KNOWN_REQUIRED) != 0)
        return fail(err, HAPTIC_TABLE_EVERSION, OFF_FLAGS, "offset %d (flags): required feature bits 0x%04lx unknown",
                    OFF_FLAGS, (unsigned long)(t.flags & FLAGS_REQUIRED_MASK));

    int rc;
    t.sample_rate_hz = rd32(b + OFF_SAMPLE_RATE);
    if ((rc = check_range_u32(err, OFF_SAMPLE_RATE, "sample_rate_hz", t.sample_rate_hz, HAPTIC_TABLE_MIN_RATE_HZ,
                              HAPTIC_TABLE_MAX_RATE_HZ)))
        return rc;
    t.channel_count = rd16(b + OFF_CHANNEL_COUNT);
    if ((rc = check_range_u32(err, OFF_CHANNEL_COUNT, "channel_count", t.channel_count, 1, HAPTIC_TABLE_MAX_CHANNELS)))
        return rc;
    t.sample_format = rd16(b + OFF_SAMPLE_FORMAT);
    if (t.sample_format != HAPTIC_SAMPLE_S16LE)
        return fail(err, HAPTIC_TABLE_EFIELD, OFF_SAMPLE_FORMAT, "offset %d (sample_format): %u, only 1 (S16LE) is known",
                    OFF_SAMPLE_FORMAT, (unsigned)t.sample_format);
    t.focus_count = rd32(b + OFF_FOCUS_COUNT);
    if ((rc = check_range_u32(err, OFF_FOCUS_COUNT, "focus_count", t.focus_count, 1, HAPTIC_TABLE_MAX_FOCI)))
        return rc;
    t.samples_per_signal = rd32(b + OFF_SAMPLES);
    if ((rc = check_range_u32(err, OFF_SAMPLES, "samples_per_signal", t.samples_per_signal, 1,
                              HAPTIC_TABLE_MAX_SAMPLES)))
        return rc;
    if (rd32(b + OFF_RESERVED0) != 0)
        return fail(err, HAPTIC_TABLE_EFIELD, OFF_RESERVED0, "offset %d (reserved0): must be 0", OFF_RESERVED0);

    uint64_t file_size = rd64(b + OFF_FILE_SIZE);
    if (file_size > HAPTIC_TABLE_MAX_FILE_SIZE)
        return fail(err, HAPTIC_TABLE_ETOOBIG, OFF_FILE_SIZE, "offset %d (file_size): %llu exceeds the %llu byte limit",
                    OFF_FILE_SIZE, (unsigned long long)file_size, (unsigned long long)HAPTIC_TABLE_MAX_FILE_SIZE);
    if (file_size != (uint64_t)size)
        return fail(err, file_size > size ? HAPTIC_TABLE_ETRUNC : HAPTIC_TABLE_ELAYOUT, OFF_FILE_SIZE,
                    "offset %d (file_size): header says %llu bytes, file has %zu", OFF_FILE_SIZE,
                    (unsigned long long)file_size, size);

    struct layout want;
    canonical_layout(t.channel_count, t.focus_count, t.samples_per_signal, &want);
    const uint64_t limit = file_size - HAPTIC_TABLE_CRC_SIZE; /* file_size >= 128 here */
    t.channels_offset = rd64(b + OFF_CHANNELS_OFFSET);
    t.foci_offset = rd64(b + OFF_FOCI_OFFSET);
    t.gram_offset = rd64(b + OFF_GRAM_OFFSET);
    t.provenance_offset = rd64(b + OFF_PROVENANCE_OFFSET);
    t.payload_offset = rd64(b + OFF_PAYLOAD_OFFSET);
    uint64_t payload_size = rd64(b + OFF_PAYLOAD_SIZE);
    if (payload_size != want.payload_size)
        return fail(err, HAPTIC_TABLE_ELAYOUT, OFF_PAYLOAD_SIZE,
                    "offset %d (payload_size): %llu, expected focus_count*samples*channels*2 = %llu", OFF_PAYLOAD_SIZE,
                    (unsigned long long)payload_size, (unsigned long long)want.payload_size);
    if ((rc = check_section(err, OFF_CHANNELS_OFFSET, "channels_offset", t.channels_offset, want.channels_size,
                            header_size, 8, limit)) ||
        (rc = check_section(err, OFF_FOCI_OFFSET, "foci_offset", t.foci_offset, want.foci_size,
                            t.channels_offset + want.channels_size, 8, limit)) ||
        (rc = check_section(err, OFF_GRAM_OFFSET, "gram_offset", t.gram_offset, want.gram_size,
                            t.foci_offset + want.foci_size, 8, limit)) ||
        (rc = check_section(err, OFF_PROVENANCE_OFFSET, "provenance_offset", t.provenance_offset,
                            want.provenance_size, t.gram_offset + want.gram_size, 8, limit)) ||
        (rc = check_section(err, OFF_PAYLOAD_OFFSET, "payload_offset", t.payload_offset, want.payload_size,
                            t.provenance_offset + want.provenance_size, HAPTIC_TABLE_PAYLOAD_ALIGN, limit)))
        return rc;
    if (t.payload_offset + want.payload_size != limit)
        return fail(err, HAPTIC_TABLE_ELAYOUT, OFF_PAYLOAD_OFFSET,
                    "offset %d (payload_offset): payload must end where the CRC trailer starts (%llu)",
                    OFF_PAYLOAD_OFFSET, (unsigned long long)limit);

    /* Integrity before meaning: every byte below is covered by the CRC. */
    t.crc32 = rd32(b + limit);
    uLong crc = crc32(0L, Z_NULL, 0);
    for (uint64_t pos = 0; pos < limit;) { /* zlib takes uInt lengths */
        uInt chunk = (uInt)((limit - pos) > (1u << 30) ? (1u << 30) : (limit - pos));
        crc = crc32(crc, b + pos, chunk);
        pos += chunk;
    }
    if ((uint32_t)crc != t.crc32)
        return fail(err, HAPTIC_TABLE_ECRC, limit, "offset %llu (crc32): stored 0x%08lx, computed 0x%08lx",
                    (unsigned long long)limit, (unsigned long)t.crc32, (unsigned long)crc);

    for (uint32_t c = 0; c < t.channel_count; c++) {
        uint64_t off = t.channels_offset + (uint64_t)c * HAPTIC_TABLE_CHANNEL_RECORD_SIZE;
        for (int k = 0; k < 2; k++) {
            double v = rdf64(b + off + 8 * k);
            if (!isfinite(v) || fabs(v) > 1e3)
                return fail(err, HAPTIC_TABLE_EFIELD, off + 8 * k,
                            "offset %llu (channel %lu %s_m): %g is not a finite position within 1 km",
                            (unsigned long long)(off + 8 * k), (unsigned long)c, k ? "y" : "x", v);
        }
    }
    for (uint32_t f = 0; f < t.focus_count; f++) {
        uint64_t off = t.foci_offset + (uint64_t)f * HAPTIC_TABLE_FOCUS_RECORD_SIZE;
        const uint8_t *r = b + off;
        if (rd32(r + FOC_RESERVED) != 0 || rd64(r + FOC_RESERVED2) != 0)
            return fail(err, HAPTIC_TABLE_EFIELD, off + FOC_RESERVED, "offset %llu (focus %lu reserved): must be 0",
                        (unsigned long long)(off + FOC_RESERVED), (unsigned long)f);
        static const char *const names[] = {"x_m", "y_m", "scale_m"};
        for (int k = 0; k < 3; k++) {
            double v = rdf64(r + FOC_X + 8 * k);
            bool ok = isfinite(v) && fabs(v) <= 1e3 && (k < 2 || v > 0.0);
            if (!ok)
                return fail(err, HAPTIC_TABLE_EFIELD, off + FOC_X + 8 * k, "offset %llu (focus %lu %s): %g is invalid",
                            (unsigned long long)(off + FOC_X + 8 * k), (unsigned long)f, names[k], v);
        }
        uint32_t id = rd32(r + FOC_ID);
        for (uint32_t g = 0; g < f; g++)
            if (rd32(b + t.foci_offset + (uint64_t)g * HAPTIC_TABLE_FOCUS_RECORD_SIZE + FOC_ID) == id)
                return fail(err, HAPTIC_TABLE_EFIELD, off + FOC_ID, "offset %llu (focus %lu id): %lu repeats focus %lu",
                            (unsigned long long)(off + FOC_ID), (unsigned long)f, (unsigned long)id,
                            (unsigned long)g);
        double energy = rdf64(r + FOC_ENERGY);
        double diag = rdf64(b + t.gram_offset + ((uint64_t)f * t.focus_count + f) * 8);
        if (!(energy > 0.0) || !isfinite(energy) || energy != diag)
            return fail(err, HAPTIC_TABLE_EGRAM, off + FOC_ENERGY,
                        "offset %llu (focus %lu energy): %g must be positive and equal Gram[%lu][%lu] = %g",
                        (unsigned long long)(off + FOC_ENERGY), (unsigned long)f, energy, (unsigned long)f,
                        (unsigned long)f, diag);
    }
    for (uint32_t i = 0; i < t.focus_count; i++) {
        double gii = rdf64(b + t.gram_offset + ((uint64_t)i * t.focus_count + i) * 8);
        for (uint32_t j = 0; j < i; j++) {
            uint64_t off = t.gram_offset + ((uint64_t)i * t.focus_count + j) * 8;
            double gij = rdf64(b + off);
            double gji = rdf64(b + t.gram_offset + ((uint64_t)j * t.focus_count + i) * 8);
            double gjj = rdf64(b + t.gram_offset + ((uint64_t)j * t.focus_count + j) * 8);
            /* Cauchy-Schwarz with a little slack for the rounding of exact integer sums to double. */
            if (!isfinite(gij) || gij != gji || fabs(gij) > sqrt(gii * gjj) * (1.0 + 1e-9))
                return fail(err, HAPTIC_TABLE_EGRAM, off,
                            "offset %llu (gram[%lu][%lu]): %g is not symmetric or violates Cauchy-Schwarz",
                            (unsigned long long)off, (unsigned long)i, (unsigned long)j, gij);
        }
    }
    const uint8_t *p = b + t.provenance_offset;
    if ((rc = check_text(err, p + PROV_SCENE_NAME, t.provenance_offset + PROV_SCENE_NAME, HAPTIC_TABLE_SCENE_NAME_LEN,
                         "scene_name")) ||
        (rc = check_text(err, p + PROV_SCENE_HASH, t.provenance_offset + PROV_SCENE_HASH, HAPTIC_TABLE_SCENE_HASH_LEN,
                         "scene_hash")) ||
        (rc = check_text(err, p + PROV_TOOL_VERSION, t.provenance_offset + PROV_TOOL_VERSION,
                         HAPTIC_TABLE_TOOL_VERSION_LEN, "tool_version")) ||
        (rc = check_text(err, p + PROV_CREATED, t.provenance_offset + PROV_CREATED, HAPTIC_TABLE_CREATED_LEN,
                         "created_utc")))
        return rc;

    t.data = b;
    t.size = size;
    *out = t;
    return 0;
}

int haptic_table_open(const char *path, haptic_table *out, haptic_table_error *err)
{
    if (!path || !out)
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "NULL path or table");
    memset(out, 0, sizeof *out);
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return fail(err, HAPTIC_TABLE_EIO, 0, "cannot open: %s", strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        int e = errno;
        close(fd);
        return fail(err, HAPTIC_TABLE_EIO, 0, "not a regular file%s%s", e ? ": " : "", e ? strerror(e) : "");
    }
    if ((uint64_t)st.st_size > HAPTIC_TABLE_MAX_FILE_SIZE) {
        close(fd);
        return fail(err, HAPTIC_TABLE_ETOOBIG, 0, "file of %lld bytes exceeds the %llu byte limit",
                    (long long)st.st_size, (unsigned long long)HAPTIC_TABLE_MAX_FILE_SIZE);
    }
    size_t size = (size_t)st.st_size;
    uint8_t *buf = malloc(size ? size : 1);
    if (!buf) {
        close(fd);
        return fail(err, HAPTIC_TABLE_ENOMEM, 0, "cannot allocate %zu bytes", size);
    }
    size_t got = 0;
    while (got < size) {
        ssize_t n = read(fd, buf + got, size - got);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            int e = n < 0 ? errno : 0;
            free(buf);
            close(fd);
            return fail(err, e ? HAPTIC_TABLE_EIO : HAPTIC_TABLE_ETRUNC, got, "read failed at offset %zu: %s", got,
                        e ? strerror(e) : "file shrank while reading");
        }
        got += (size_t)n;
    }
    close(fd);
    int rc = haptic_table_validate(buf, size, out, err);
    if (rc) {
        free(buf);
        memset(out, 0, sizeof *out);
        return rc;
    }
    out->owned = buf;
    return 0;
}

void haptic_table_close(haptic_table *t)
{
    if (!t)
        return;
    free(t->owned);
    memset(t, 0, sizeof *t);
}

int haptic_table_focus(const haptic_table *t, uint32_t index, haptic_focus_info *out)
{
    if (!t || !t->data || !out || index >= t->focus_count)
        return HAPTIC_TABLE_EINVAL;
    const uint8_t *r = t->data + t->foci_offset + (uint64_t)index * HAPTIC_TABLE_FOCUS_RECORD_SIZE;
    out->id = rd32(r + FOC_ID);
    out->x_m = rdf64(r + FOC_X);
    out->y_m = rdf64(r + FOC_Y);
    out->scale_m = rdf64(r + FOC_SCALE);
    out->energy = rdf64(r + FOC_ENERGY);
    return 0;
}

int haptic_table_channel_position(const haptic_table *t, uint32_t channel, double *x_m, double *y_m)
{
    if (!t || !t->data || channel >= t->channel_count)
        return HAPTIC_TABLE_EINVAL;
    const uint8_t *r = t->data + t->channels_offset + (uint64_t)channel * HAPTIC_TABLE_CHANNEL_RECORD_SIZE;
    if (x_m)
        *x_m = rdf64(r);
    if (y_m)
        *y_m = rdf64(r + 8);
    return 0;
}

double haptic_table_gram(const haptic_table *t, uint32_t i, uint32_t j)
{
    if (!t || !t->data || i >= t->focus_count || j >= t->focus_count)
        return NAN;
    return rdf64(t->data + t->gram_offset + ((uint64_t)i * t->focus_count + j) * 8);
}

const int16_t *haptic_table_signal(const haptic_table *t, uint32_t focus)
{
    if (!t || !t->data || focus >= t->focus_count)
        return NULL;
    /* The payload offset is 64-aligned in the file and the buffer comes from
     * malloc (or the caller), so the int16 view is aligned. */
    const void *p = t->data + t->payload_offset +
                    (uint64_t)focus * t->samples_per_signal * t->channel_count * sizeof(int16_t);
    return (const int16_t *)p;
}

static void copy_text(char *dst, const uint8_t *src, size_t len)
{
    memcpy(dst, src, len);
    dst[len] = '\0';
}

void haptic_table_provenance(const haptic_table *t, haptic_provenance *out)
{
    memset(out, 0, sizeof *out);
    if (!t || !t->data)
        return;
    const uint8_t *p = t->data + t->provenance_offset;
    copy_text(out->scene_name, p + PROV_SCENE_NAME, HAPTIC_TABLE_SCENE_NAME_LEN);
    copy_text(out->scene_hash, p + PROV_SCENE_HASH, HAPTIC_TABLE_SCENE_HASH_LEN);
    copy_text(out->tool_version, p + PROV_TOOL_VERSION, HAPTIC_TABLE_TOOL_VERSION_LEN);
    copy_text(out->created_utc, p + PROV_CREATED, HAPTIC_TABLE_CREATED_LEN);
}

int32_t haptic_table_find_focus(const haptic_table *t, uint32_t id)
{
    if (!t || !t->data)
        return -1;
    for (uint32_t f = 0; f < t->focus_count; f++)
        if (rd32(t->data + t->foci_offset + (uint64_t)f * HAPTIC_TABLE_FOCUS_RECORD_SIZE + FOC_ID) == id)
            return (int32_t)f;
    return -1;
}

/* ---- writer ---- */

static int spec_check(const haptic_table_spec *s, haptic_table_error *err)
{
    if (!s || !s->channel_xy_m || !s->focus_id || !s->focus_xy_m || !s->focus_scale_m || !s->samples)
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "table spec has a NULL array");
    if (s->sample_rate_hz < HAPTIC_TABLE_MIN_RATE_HZ || s->sample_rate_hz > HAPTIC_TABLE_MAX_RATE_HZ)
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "sample_rate_hz %lu outside %u..%u", (unsigned long)s->sample_rate_hz,
                    HAPTIC_TABLE_MIN_RATE_HZ, HAPTIC_TABLE_MAX_RATE_HZ);
    if (s->channel_count < 1 || s->channel_count > HAPTIC_TABLE_MAX_CHANNELS)
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "channel_count %u outside 1..%u", (unsigned)s->channel_count,
                    HAPTIC_TABLE_MAX_CHANNELS);
    if (s->focus_count < 1 || s->focus_count > HAPTIC_TABLE_MAX_FOCI)
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "focus_count %lu outside 1..%u", (unsigned long)s->focus_count,
                    HAPTIC_TABLE_MAX_FOCI);
    if (s->samples_per_signal < 1 || s->samples_per_signal > HAPTIC_TABLE_MAX_SAMPLES)
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "samples_per_signal %lu outside 1..%u",
                    (unsigned long)s->samples_per_signal, HAPTIC_TABLE_MAX_SAMPLES);
    struct layout l;
    canonical_layout(s->channel_count, s->focus_count, s->samples_per_signal, &l);
    if (l.file_size > HAPTIC_TABLE_MAX_FILE_SIZE)
        return fail(err, HAPTIC_TABLE_ETOOBIG, 0, "table of %llu bytes exceeds the %llu byte limit",
                    (unsigned long long)l.file_size, (unsigned long long)HAPTIC_TABLE_MAX_FILE_SIZE);
    const char *texts[] = {s->scene_name, s->scene_hash, s->tool_version, s->created_utc};
    const char *names[] = {"scene_name", "scene_hash", "tool_version", "created_utc"};
    for (int i = 0; i < 4; i++) {
        if (!texts[i])
            continue;
        size_t n = strlen(texts[i]);
        if (n > 64)
            return fail(err, HAPTIC_TABLE_EINVAL, 0, "%s is %zu bytes, at most 64", names[i], n);
        for (size_t k = 0; k < n; k++)
            if ((unsigned char)texts[i][k] < 0x20 || texts[i][k] == 0x7f)
                return fail(err, HAPTIC_TABLE_EINVAL, 0, "%s has a control character", names[i]);
    }
    return 0;
}

uint64_t haptic_table_encoded_size(const haptic_table_spec *spec)
{
    if (spec_check(spec, NULL))
        return 0;
    struct layout l;
    canonical_layout(spec->channel_count, spec->focus_count, spec->samples_per_signal, &l);
    return l.file_size;
}

int haptic_table_encode(const haptic_table_spec *s, void *buf, size_t size, haptic_table_error *err)
{
    int rc = spec_check(s, err);
    if (rc)
        return rc;
    struct layout l;
    canonical_layout(s->channel_count, s->focus_count, s->samples_per_signal, &l);
    if (!buf || size < l.file_size)
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "output buffer of %zu bytes, need %llu", size,
                    (unsigned long long)l.file_size);
    uint8_t *b = buf;
    memset(b, 0, l.file_size);
    memcpy(b + OFF_MAGIC, HAPTIC_TABLE_MAGIC, 8);
    wr16(b + OFF_VERSION_MAJOR, HAPTIC_TABLE_VERSION_MAJOR);
    wr16(b + OFF_VERSION_MINOR, HAPTIC_TABLE_VERSION_MINOR);
    wr32(b + OFF_HEADER_SIZE, HAPTIC_TABLE_HEADER_SIZE);
    wr32(b + OFF_FLAGS, 0);
    wr32(b + OFF_SAMPLE_RATE, s->sample_rate_hz);
    wr16(b + OFF_CHANNEL_COUNT, s->channel_count);
    wr16(b + OFF_SAMPLE_FORMAT, HAPTIC_SAMPLE_S16LE);
    wr32(b + OFF_FOCUS_COUNT, s->focus_count);
    wr32(b + OFF_SAMPLES, s->samples_per_signal);
    wr64(b + OFF_FILE_SIZE, l.file_size);
    wr64(b + OFF_CHANNELS_OFFSET, l.channels_offset);
    wr64(b + OFF_FOCI_OFFSET, l.foci_offset);
    wr64(b + OFF_GRAM_OFFSET, l.gram_offset);
    wr64(b + OFF_PROVENANCE_OFFSET, l.provenance_offset);
    wr64(b + OFF_PAYLOAD_OFFSET, l.payload_offset);
    wr64(b + OFF_PAYLOAD_SIZE, l.payload_size);

    for (uint32_t c = 0; c < s->channel_count; c++) {
        uint8_t *r = b + l.channels_offset + (uint64_t)c * HAPTIC_TABLE_CHANNEL_RECORD_SIZE;
        wrf64(r, s->channel_xy_m[2 * c]);
        wrf64(r + 8, s->channel_xy_m[2 * c + 1]);
    }
    const uint64_t per_focus = (uint64_t)s->samples_per_signal * s->channel_count;
    uint8_t *payload = b + l.payload_offset;
    for (uint64_t i = 0; i < per_focus * s->focus_count; i++)
        wr16(payload + 2 * i, (uint16_t)s->samples[i]);
    /* Gram matrix: exact integer inner products (|s| <= 32768, so each
     * product fits in 31 bits and up to 2^32 of them in an int64), rounded
     * once to double. */
    for (uint32_t i = 0; i < s->focus_count; i++) {
        const int16_t *si = s->samples + i * per_focus;
        for (uint32_t j = 0; j <= i; j++) {
            const int16_t *sj = s->samples + j * per_focus;
            int64_t acc = 0;
            for (uint64_t n = 0; n < per_focus; n++)
                acc += (int32_t)si[n] * (int32_t)sj[n];
            wrf64(b + l.gram_offset + ((uint64_t)i * s->focus_count + j) * 8, (double)acc);
            wrf64(b + l.gram_offset + ((uint64_t)j * s->focus_count + i) * 8, (double)acc);
        }
    }
    for (uint32_t f = 0; f < s->focus_count; f++) {
        uint8_t *r = b + l.foci_offset + (uint64_t)f * HAPTIC_TABLE_FOCUS_RECORD_SIZE;
        wr32(r + FOC_ID, s->focus_id[f]);
        wrf64(r + FOC_X, s->focus_xy_m[2 * f]);
        wrf64(r + FOC_Y, s->focus_xy_m[2 * f + 1]);
        wrf64(r + FOC_SCALE, s->focus_scale_m[f]);
        memcpy(r + FOC_ENERGY, b + l.gram_offset + ((uint64_t)f * s->focus_count + f) * 8, 8);
    }
    const char *texts[] = {s->scene_name, s->scene_hash, s->tool_version, s->created_utc};
    const unsigned offs[] = {PROV_SCENE_NAME, PROV_SCENE_HASH, PROV_TOOL_VERSION, PROV_CREATED};
    for (int i = 0; i < 4; i++)
        if (texts[i])
            memcpy(b + l.provenance_offset + offs[i], texts[i], strlen(texts[i]));

    uLong crc = crc32(crc32(0L, Z_NULL, 0), b, (uInt)(l.file_size - HAPTIC_TABLE_CRC_SIZE));
    wr32(b + l.file_size - HAPTIC_TABLE_CRC_SIZE, (uint32_t)crc);

    /* The writer refuses to produce what the reader would refuse (e.g. an
     * all-zero focus signal, a non-finite position, a repeated id). */
    haptic_table check;
    return haptic_table_validate(b, l.file_size, &check, err);
}

static int write_all(int fd, const uint8_t *p, size_t n)
{
    while (n > 0) {
        ssize_t w = write(fd, p, n);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0)
            return -1;
        p += w;
        n -= (size_t)w;
    }
    return 0;
}

int haptic_table_write(const char *path, const haptic_table_spec *spec, haptic_table_error *err)
{
    if (!path)
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "NULL path");
    uint64_t size = haptic_table_encoded_size(spec);
    if (size == 0)
        return spec_check(spec, err);
    uint8_t *buf = malloc((size_t)size);
    if (!buf)
        return fail(err, HAPTIC_TABLE_ENOMEM, 0, "cannot allocate %llu bytes", (unsigned long long)size);
    int rc = haptic_table_encode(spec, buf, (size_t)size, err);
    if (rc) {
        free(buf);
        return rc;
    }
    size_t plen = strlen(path);
    char *tmp = malloc(plen + 16);
    if (!tmp) {
        free(buf);
        return fail(err, HAPTIC_TABLE_ENOMEM, 0, "out of memory");
    }
    snprintf(tmp, plen + 16, "%s.tmp.XXXXXX", path);
    int fd = mkstemp(tmp);
    if (fd < 0) {
        rc = fail(err, HAPTIC_TABLE_EIO, 0, "cannot create %s: %s", tmp, strerror(errno));
        goto out;
    }
    if (fchmod(fd, 0644) != 0 || write_all(fd, buf, (size_t)size) != 0 || fsync(fd) != 0) {
        rc = fail(err, HAPTIC_TABLE_EIO, 0, "cannot write %s: %s", tmp, strerror(errno));
        close(fd);
        unlink(tmp);
        goto out;
    }
    if (close(fd) != 0 || rename(tmp, path) != 0) {
        rc = fail(err, HAPTIC_TABLE_EIO, 0, "cannot move %s into place: %s", tmp, strerror(errno));
        unlink(tmp);
        goto out;
    }
    /* Make the rename itself durable (best effort: some filesystems refuse). */
    char *slash = strrchr(tmp, '/');
    if (slash) {
        *slash = '\0';
        int dfd = open(slash == tmp ? "/" : tmp, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (dfd >= 0) {
            fsync(dfd);
            close(dfd);
        }
    } else {
        int dfd = open(".", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (dfd >= 0) {
            fsync(dfd);
            close(dfd);
        }
    }
    rc = 0;
out:
    free(tmp);
    free(buf);
    return rc;
}

int haptic_table_print_summary(const haptic_table *t, const char *path, FILE *out)
{
    if (!t || !t->data || !out)
        return HAPTIC_TABLE_EINVAL;
    haptic_provenance p;
    haptic_table_provenance(t, &p);
    double seconds = (double)t->samples_per_signal / t->sample_rate_hz;
    fprintf(out, "table        %s (%zu bytes, format 1.%u, CRC-32 0x%08lx ok)\n", path ? path : "-", t->size,
            (unsigned)t->format_minor, (unsigned long)t->crc32);
    fprintf(out, "scene        %s (hash %s)\n", p.scene_name[0] ? p.scene_name : "?", p.scene_hash[0] ? p.scene_hash : "?");
    fprintf(out, "written by   %s on %s\n", p.tool_version[0] ? p.tool_version : "?", p.created_utc[0] ? p.created_utc : "?");
    fprintf(out, "signals      %lu foci x %u channels x %lu samples S16LE at %lu Hz (%.1f ms each)\n",
            (unsigned long)t->focus_count, (unsigned)t->channel_count, (unsigned long)t->samples_per_signal,
            (unsigned long)t->sample_rate_hz, 1e3 * seconds);
    for (uint32_t c = 0; c < t->channel_count; c++) {
        double x, y;
        haptic_table_channel_position(t, c, &x, &y);
        fprintf(out, "exciter %-4lu (%8.1f, %8.1f) mm\n", (unsigned long)c, 1e3 * x, 1e3 * y);
    }
    for (uint32_t f = 0; f < t->focus_count; f++) {
        haptic_focus_info fi;
        haptic_table_focus(t, f, &fi);
        double rms = sqrt(fi.energy / ((double)t->samples_per_signal * t->channel_count)) / 32767.0;
        fprintf(out, "focus id %-4lu (%8.1f, %8.1f) mm  full scale -> %.3g um  rms %.3f FS\n", (unsigned long)fi.id,
                1e3 * fi.x_m, 1e3 * fi.y_m, 1e6 * fi.scale_m, rms);
    }
    return 0;
}
