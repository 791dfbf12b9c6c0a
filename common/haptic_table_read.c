/* haptic_table_read.c - the reader: header, section layout and CRC-32, then
 * the content checks (haptic_table_content.c); open, close and accessors.
 * This is all the device links. Field layout: docs/table-format.md. */
#define _POSIX_C_SOURCE 200809L
#include "haptic_table_internal.h"
#include "haptic_file.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>
#include <zlib.h>

int haptic_table_fail_(haptic_table_error *err, int code, uint64_t offset, const char *fmt, ...)
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
#define fail haptic_table_fail_

const char *haptic_table_error_string(int code)
{
    switch (code) {
    case HAPTIC_TABLE_OK:
        return "ok";
    case HAPTIC_TABLE_EIO:
        return "I/O error";
    case HAPTIC_TABLE_ENOMEM:
        return "out of memory";
    case HAPTIC_TABLE_ETRUNC:
        return "truncated table";
    case HAPTIC_TABLE_EMAGIC:
        return "not a haptic table (bad magic)";
    case HAPTIC_TABLE_EVERSION:
        return "unsupported table format version";
    case HAPTIC_TABLE_EFIELD:
        return "field out of range";
    case HAPTIC_TABLE_ELAYOUT:
        return "inconsistent section layout";
    case HAPTIC_TABLE_ECRC:
        return "CRC-32 mismatch (corrupted table)";
    case HAPTIC_TABLE_EGRAM:
        return "inconsistent Gram matrix";
    case HAPTIC_TABLE_EINVAL:
        return "invalid argument";
    case HAPTIC_TABLE_ETOOBIG:
        return "table too large";
    default:
        return "unknown error";
    }
}

const char *haptic_drive_kind_name(int kind)
{
    switch (kind) {
    case HAPTIC_DRIVE_FORCE:
        return "force on the plate";
    case HAPTIC_DRIVE_EXCITER:
        return "exciter drive (Bl i)";
    case HAPTIC_DRIVE_EXCITER_PRECOMPENSATED:
        return "exciter drive (Bl i), pre-compensated";
    default:
        return "unknown";
    }
}

static int check_range_u32(haptic_table_error *err, uint64_t off, const char *field, uint32_t v, uint32_t lo,
                           uint32_t hi)
{
    if (v < lo || v > hi)
        return fail(err, HAPTIC_TABLE_EFIELD, off, "offset %llu (%s): %lu is outside %lu..%lu", (unsigned long long)off,
                    field, (unsigned long)v, (unsigned long)lo, (unsigned long)hi);
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

/* Steps 1-4 of the reader's order: magic, version, header fields, size. */
static int check_header(const uint8_t *b, size_t size, haptic_table *t, uint32_t *header_size, haptic_table_error *err)
{
    if (size < 12)
        return fail(err, HAPTIC_TABLE_ETRUNC, size, "offset %zu: file of %zu bytes ends inside the header", size, size);
    if (memcmp(b + OFF_MAGIC, HAPTIC_TABLE_MAGIC, 8) != 0)
        return fail(err, HAPTIC_TABLE_EMAGIC, 0, "offset 0 (magic): not a haptic table");
    uint16_t major = rd16(b + OFF_VERSION_MAJOR);
    if (major != HAPTIC_TABLE_VERSION_MAJOR)
        return fail(err, HAPTIC_TABLE_EVERSION, OFF_VERSION_MAJOR,
                    "offset %d (format_major): version %u, this reader reads version %u", OFF_VERSION_MAJOR,
                    (unsigned)major, HAPTIC_TABLE_VERSION_MAJOR);
    t->format_minor = rd16(b + OFF_VERSION_MINOR);
    if (size < HAPTIC_TABLE_HEADER_SIZE)
        return fail(err, HAPTIC_TABLE_ETRUNC, size, "offset %zu: file of %zu bytes ends inside the header", size, size);
    *header_size = rd32(b + OFF_HEADER_SIZE);
    if (*header_size < HAPTIC_TABLE_HEADER_SIZE || *header_size > 4096 || *header_size % 8 != 0)
        return fail(err, HAPTIC_TABLE_EFIELD, OFF_HEADER_SIZE,
                    "offset %d (header_size): %lu, expected a multiple of 8 in %u..4096", OFF_HEADER_SIZE,
                    (unsigned long)*header_size, HAPTIC_TABLE_HEADER_SIZE);
    if (t->format_minor <= HAPTIC_TABLE_VERSION_MINOR && *header_size != HAPTIC_TABLE_HEADER_SIZE)
        return fail(err, HAPTIC_TABLE_EFIELD, OFF_HEADER_SIZE, "offset %d (header_size): %lu, version 1.%u has %u",
                    OFF_HEADER_SIZE, (unsigned long)*header_size, (unsigned)t->format_minor, HAPTIC_TABLE_HEADER_SIZE);
    t->flags = rd32(b + OFF_FLAGS);
    if ((t->flags & FLAGS_REQUIRED_MASK & ~FLAGS_KNOWN_REQUIRED) != 0)
        return fail(err, HAPTIC_TABLE_EVERSION, OFF_FLAGS, "offset %d (flags): required feature bits 0x%04lx unknown",
                    OFF_FLAGS, (unsigned long)(t->flags & FLAGS_REQUIRED_MASK));

    int rc;
    t->sample_rate_hz = rd32(b + OFF_SAMPLE_RATE);
    if ((rc = check_range_u32(err, OFF_SAMPLE_RATE, "sample_rate_hz", t->sample_rate_hz, HAPTIC_TABLE_MIN_RATE_HZ,
                              HAPTIC_TABLE_MAX_RATE_HZ)))
        return rc;
    t->channel_count = rd16(b + OFF_CHANNEL_COUNT);
    if ((rc = check_range_u32(err, OFF_CHANNEL_COUNT, "channel_count", t->channel_count, 1, HAPTIC_TABLE_MAX_CHANNELS)))
        return rc;
    t->sample_format = rd16(b + OFF_SAMPLE_FORMAT);
    if (t->sample_format != HAPTIC_SAMPLE_S16LE)
        return fail(err, HAPTIC_TABLE_EFIELD, OFF_SAMPLE_FORMAT,
                    "offset %d (sample_format): %u, only 1 (S16LE) is known", OFF_SAMPLE_FORMAT,
                    (unsigned)t->sample_format);
    t->focus_count = rd32(b + OFF_FOCUS_COUNT);
    if ((rc = check_range_u32(err, OFF_FOCUS_COUNT, "focus_count", t->focus_count, 1, HAPTIC_TABLE_MAX_FOCI)))
        return rc;
    t->samples_per_signal = rd32(b + OFF_SAMPLES);
    if ((rc = check_range_u32(err, OFF_SAMPLES, "samples_per_signal", t->samples_per_signal, 1,
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
    return 0;
}

/* Step 5: sections in order, aligned, inside [header_size, file_size - 4),
 * the payload ending at the trailer. */
static int check_layout(const uint8_t *b, uint64_t file_size, uint32_t header_size, haptic_table *t,
                        haptic_table_error *err)
{
    const bool playback = t->format_minor >= 1 && (t->flags & HAPTIC_TABLE_FLAG_PLAYBACK);
    const bool panel = t->format_minor >= 2 && (t->flags & HAPTIC_TABLE_FLAG_PANEL);
    const bool range = t->format_minor >= 3 && (t->flags & HAPTIC_TABLE_FLAG_RANGE);
    struct layout want;
    canonical_layout(t->channel_count, t->focus_count, t->samples_per_signal, playback, panel, range, &want);
    const uint64_t limit = file_size - HAPTIC_TABLE_CRC_SIZE; /* file_size >= 128 here */
    t->channels_offset = rd64(b + OFF_CHANNELS_OFFSET);
    t->foci_offset = rd64(b + OFF_FOCI_OFFSET);
    t->gram_offset = rd64(b + OFF_GRAM_OFFSET);
    t->provenance_offset = rd64(b + OFF_PROVENANCE_OFFSET);
    t->payload_offset = rd64(b + OFF_PAYLOAD_OFFSET);
    uint64_t payload_size = rd64(b + OFF_PAYLOAD_SIZE);
    if (payload_size != want.payload_size)
        return fail(err, HAPTIC_TABLE_ELAYOUT, OFF_PAYLOAD_SIZE,
                    "offset %d (payload_size): %llu, expected focus_count*samples*channels*2 = %llu", OFF_PAYLOAD_SIZE,
                    (unsigned long long)payload_size, (unsigned long long)want.payload_size);
    int rc;
    if ((rc = check_section(err, OFF_CHANNELS_OFFSET, "channels_offset", t->channels_offset, want.channels_size,
                            header_size, 8, limit)) ||
        (rc = check_section(err, OFF_FOCI_OFFSET, "foci_offset", t->foci_offset, want.foci_size,
                            t->channels_offset + want.channels_size, 8, limit)) ||
        (rc = check_section(err, OFF_GRAM_OFFSET, "gram_offset", t->gram_offset, want.gram_size,
                            t->foci_offset + want.foci_size, 8, limit)) ||
        (rc = check_section(err, OFF_PROVENANCE_OFFSET, "provenance_offset", t->provenance_offset, want.provenance_size,
                            t->gram_offset + want.gram_size, 8, limit)))
        return rc;
    uint64_t end = t->provenance_offset + want.provenance_size;
    if (playback) {
        t->playback_offset = rd64(b + OFF_PLAYBACK_OFFSET);
        if ((rc = check_section(err, OFF_PLAYBACK_OFFSET, "playback_offset", t->playback_offset, want.playback_size,
                                end, 8, limit)))
            return rc;
        end = t->playback_offset + want.playback_size;
    }
    if (panel) {
        t->panel_offset = rd64(b + OFF_PANEL_OFFSET);
        if ((rc =
                 check_section(err, OFF_PANEL_OFFSET, "panel_offset", t->panel_offset, want.panel_size, end, 8, limit)))
            return rc;
        end = t->panel_offset + want.panel_size;
    }
    if (range) {
        t->range_offset = rd64(b + OFF_RANGE_OFFSET);
        if ((rc =
                 check_section(err, OFF_RANGE_OFFSET, "range_offset", t->range_offset, want.range_size, end, 8, limit)))
            return rc;
        end = t->range_offset + want.range_size;
    }
    if ((rc = check_section(err, OFF_PAYLOAD_OFFSET, "payload_offset", t->payload_offset, want.payload_size, end,
                            HAPTIC_TABLE_PAYLOAD_ALIGN, limit)))
        return rc;
    if (t->payload_offset + want.payload_size != limit)
        return fail(err, HAPTIC_TABLE_ELAYOUT, OFF_PAYLOAD_OFFSET,
                    "offset %d (payload_offset): payload must end where the CRC trailer starts (%llu)",
                    OFF_PAYLOAD_OFFSET, (unsigned long long)limit);
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
    if ((uintptr_t)data % 2 != 0) /* the payload is read in place as int16 */
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "table buffer at an odd address");
    const uint8_t *b = data;
    haptic_table t;
    memset(&t, 0, sizeof t);
    uint32_t header_size = 0;
    int rc;
    if ((rc = check_header(b, size, &t, &header_size, err)) || (rc = check_layout(b, size, header_size, &t, err)))
        return rc;

    /* Integrity before meaning: every byte below is covered by the CRC. */
    const uint64_t limit = size - HAPTIC_TABLE_CRC_SIZE;
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

    if ((rc = haptic_table_check_content_(b, &t, err)))
        return rc;
    t.force_full_scale_n = NAN;
    t.drive_kind = HAPTIC_DRIVE_UNKNOWN;
    if (t.playback_offset) {
        t.force_full_scale_n = rdf64(b + t.playback_offset + PLAY_FORCE);
        t.drive_kind = rd16(b + t.playback_offset + PLAY_DRIVE_KIND);
    }
    t.data = b;
    t.size = size;
    *out = t;
    return 0;
}

/* Steps 1-5 on the header alone: check_header and check_layout read only the
 * fixed header (its first HAPTIC_TABLE_HEADER_SIZE bytes) and take the file's
 * size as given, so they run on a prefix before the file is read. */
static int check_prefix(int fd, size_t size, haptic_table_error *err)
{
    _Alignas(8) uint8_t head[HAPTIC_TABLE_HEADER_SIZE];
    size_t want = size < sizeof head ? size : sizeof head, got = 0;
    while (got < want) {
        ssize_t n = pread(fd, head + got, want - got, (off_t)got);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            int e = n < 0 ? errno : 0;
            return fail(err, e ? HAPTIC_TABLE_EIO : HAPTIC_TABLE_ETRUNC, got, "read failed at offset %zu: %s", got,
                        e ? strerror(e) : "file shrank while reading");
        }
        got += (size_t)n;
    }
    haptic_table t;
    memset(&t, 0, sizeof t);
    uint32_t header_size = 0;
    int rc = check_header(head, size, &t, &header_size, err);
    return rc ? rc : check_layout(head, size, header_size, &t, err);
}

int haptic_table_open(const char *path, haptic_table *out, haptic_table_error *err)
{
    if (!path || !out)
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "NULL path or table");
    memset(out, 0, sizeof *out);
    /* Not blocked on (a FIFO or a device at the path is refused as not a
     * regular file), and bounded before anything is read (haptic_file.h). */
    int fd;
    haptic_file_status fs;
    if (haptic_file_open_regular(path, HAPTIC_TABLE_MAX_FILE_SIZE, &fd, &fs) != 0) {
        const int e = fs.error;
        if (fs.refusal == HAPTIC_FILE_CANNOT_OPEN)
            return fail(err, HAPTIC_TABLE_EIO, 0, "cannot open: %s", strerror(e));
        if (fs.refusal == HAPTIC_FILE_NOT_REGULAR)
            return fail(err, HAPTIC_TABLE_EIO, 0, "not a regular file%s%s", e ? ": " : "", e ? strerror(e) : "");
        return fail(err, HAPTIC_TABLE_ETOOBIG, 0, "file of %lld bytes exceeds the %llu byte limit", (long long)fs.size,
                    (unsigned long long)HAPTIC_TABLE_MAX_FILE_SIZE);
    }
    size_t size = (size_t)fs.size;
    /* The header first: a file that is no table, or whose header disagrees
     * with its size, is refused before anything is allocated, so reading a
     * large file that is not a table costs one header's read. What is
     * allocated below is what the header's own sizes (checked against the
     * format's limits) say the table holds. */
    int rc = check_prefix(fd, size, err);
    if (rc) {
        close(fd);
        return rc;
    }
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
    rc = haptic_table_validate(buf, size, out, err);
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

int haptic_table_panel(const haptic_table *t, haptic_panel *out)
{
    if (!t || !t->data || !out || !t->panel_offset)
        return -1;
    out->temperature_c = rdf64(t->data + t->panel_offset + PANEL_TEMPERATURE);
    out->youngs_per_k = rdf64(t->data + t->panel_offset + PANEL_YOUNGS_PER_K);
    return 0;
}

int haptic_table_gain_range(const haptic_table *t, uint32_t index, haptic_gain_range *out)
{
    if (!t || !t->data || !out || !t->range_offset || index >= t->focus_count)
        return -1;
    const uint8_t *r = t->data + t->range_offset + RANGE_GAINS + (uint64_t)index * 16;
    out->lo = rdf64(r);
    out->hi = rdf64(r + 8);
    return 0;
}

double haptic_table_range_threshold_m(const haptic_table *t)
{
    return t && t->data && t->range_offset ? rdf64(t->data + t->range_offset + RANGE_THRESHOLD) : NAN;
}

int haptic_table_range_scope(const haptic_table *t)
{
    return t && t->data && t->range_offset ? rd16(t->data + t->range_offset + RANGE_SCOPE) : 0;
}

double haptic_table_lead_time_s(const haptic_table *t, uint32_t index)
{
    if (!t || !t->data || index >= t->focus_count || !t->playback_offset)
        return NAN;
    return rdf64(t->data + t->playback_offset + PLAY_LEAD_TIMES + (uint64_t)index * 8);
}

double haptic_table_force_full_scale_n(const haptic_table *t) { return t && t->data ? t->force_full_scale_n : NAN; }

int haptic_table_drive_kind(const haptic_table *t) { return t && t->data ? t->drive_kind : HAPTIC_DRIVE_UNKNOWN; }

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
    out->lead_time_s = haptic_table_lead_time_s(t, index);
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
    const void *p =
        t->data + t->payload_offset + (uint64_t)focus * t->samples_per_signal * t->channel_count * sizeof(int16_t);
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
