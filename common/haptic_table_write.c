/* haptic_table_write.c - the writer: encodes a spec into the format the
 * reader checks (docs/table-format.md) and replaces a file atomically.
 * calibgen links it; the device does not. */
#define _POSIX_C_SOURCE 200809L
#include "haptic_table_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#define fail haptic_table_fail_

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
    if (s->drive_kind != HAPTIC_DRIVE_UNKNOWN && !s->focus_lead_time_s)
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "table spec has a drive kind but no lead times");
    if (s->range && !s->range->focus)
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "table spec has a range section but no per-focus ranges");
    struct layout l;
    canonical_layout(s->channel_count, s->focus_count, s->samples_per_signal, s->drive_kind != HAPTIC_DRIVE_UNKNOWN,
                     s->panel != NULL, s->range != NULL, &l);
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
    canonical_layout(spec->channel_count, spec->focus_count, spec->samples_per_signal,
                     spec->drive_kind != HAPTIC_DRIVE_UNKNOWN, spec->panel != NULL, spec->range != NULL, &l);
    return l.file_size;
}

int haptic_table_encode(const haptic_table_spec *s, void *buf, size_t size, haptic_table_error *err)
{
    int rc = spec_check(s, err);
    if (rc)
        return rc;
    const bool playback = s->drive_kind != HAPTIC_DRIVE_UNKNOWN;
    struct layout l;
    canonical_layout(s->channel_count, s->focus_count, s->samples_per_signal, playback, s->panel != NULL,
                     s->range != NULL, &l);
    if (!buf || size < l.file_size)
        return fail(err, HAPTIC_TABLE_EINVAL, 0, "output buffer of %zu bytes, need %llu", size,
                    (unsigned long long)l.file_size);
    uint8_t *b = buf;
    memset(b, 0, l.file_size);
    memcpy(b + OFF_MAGIC, HAPTIC_TABLE_MAGIC, 8);
    wr16(b + OFF_VERSION_MAJOR, HAPTIC_TABLE_VERSION_MAJOR);
    wr16(b + OFF_VERSION_MINOR, HAPTIC_TABLE_VERSION_MINOR);
    wr32(b + OFF_HEADER_SIZE, HAPTIC_TABLE_HEADER_SIZE);
    wr32(b + OFF_FLAGS, (playback ? HAPTIC_TABLE_FLAG_PLAYBACK : 0) | (s->panel ? HAPTIC_TABLE_FLAG_PANEL : 0) |
                            (s->range ? HAPTIC_TABLE_FLAG_RANGE : 0));
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
    wr64(b + OFF_PLAYBACK_OFFSET, l.playback_offset);
    wr64(b + OFF_PANEL_OFFSET, l.panel_offset);
    wr64(b + OFF_RANGE_OFFSET, l.range_offset);

    for (uint32_t c = 0; c < s->channel_count; c++) {
        uint8_t *r = b + l.channels_offset + (uint64_t)c * HAPTIC_TABLE_CHANNEL_RECORD_SIZE;
        wrf64(r, s->channel_xy_m[2 * c]);
        wrf64(r + 8, s->channel_xy_m[2 * c + 1]);
    }
    const uint64_t per_focus = (uint64_t)s->samples_per_signal * s->channel_count;
    uint8_t *payload = b + l.payload_offset;
    for (uint64_t i = 0; i < per_focus * s->focus_count; i++)
        wr16(payload + 2 * i, (uint16_t)s->samples[i]);
    /* Gram matrix: exact integer inner products, rounded once to double. */
    for (uint32_t i = 0; i < s->focus_count; i++) {
        for (uint32_t j = 0; j <= i; j++) {
            double g = (double)haptic_table_dot_(s->samples + i * per_focus, s->samples + j * per_focus, per_focus);
            wrf64(b + l.gram_offset + ((uint64_t)i * s->focus_count + j) * 8, g);
            wrf64(b + l.gram_offset + ((uint64_t)j * s->focus_count + i) * 8, g);
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
    if (playback) {
        uint8_t *p = b + l.playback_offset;
        wrf64(p + PLAY_FORCE, s->force_full_scale_n);
        wr16(p + PLAY_DRIVE_KIND, s->drive_kind);
        for (uint32_t f = 0; f < s->focus_count; f++)
            wrf64(p + PLAY_LEAD_TIMES + (uint64_t)f * 8, s->focus_lead_time_s[f]);
    }
    if (s->panel) {
        wrf64(b + l.panel_offset + PANEL_TEMPERATURE, s->panel->temperature_c);
        wrf64(b + l.panel_offset + PANEL_YOUNGS_PER_K, s->panel->youngs_per_k);
    }
    if (s->range) {
        uint8_t *p = b + l.range_offset;
        wrf64(p + RANGE_THRESHOLD, s->range->threshold_m);
        wr16(p + RANGE_SCOPE, s->range->scope);
        for (uint32_t f = 0; f < s->focus_count; f++) {
            wrf64(p + RANGE_GAINS + (uint64_t)f * 16, s->range->focus[f].lo);
            wrf64(p + RANGE_GAINS + (uint64_t)f * 16 + 8, s->range->focus[f].hi);
        }
    }
    const char *texts[] = {s->scene_name, s->scene_hash, s->tool_version, s->created_utc};
    const unsigned offs[] = {PROV_SCENE_NAME, PROV_SCENE_HASH, PROV_TOOL_VERSION, PROV_CREATED};
    for (int i = 0; i < 4; i++)
        if (texts[i])
            memcpy(b + l.provenance_offset + offs[i], texts[i], strlen(texts[i]));

    uLong crc = crc32(crc32(0L, Z_NULL, 0), b, (uInt)(l.file_size - HAPTIC_TABLE_CRC_SIZE));
    wr32(b + l.file_size - HAPTIC_TABLE_CRC_SIZE, (uint32_t)crc);

    /* The writer refuses to produce what the reader would refuse (e.g. an
     * all-zero focus signal, a non-finite position, a repeated id, a lead
     * time outside the signal, a NaN or negative safe gain, text that is not
     * UTF-8). */
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
