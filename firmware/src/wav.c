/* wav.c - wav.h. */
#define _GNU_SOURCE
#include "wav.h"

#include <haptic_file.h>

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static uint32_t le16(const uint8_t *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8; }
static uint32_t le32(const uint8_t *p) { return le16(p) | le16(p + 2) << 16; }

void hd_wav_free(struct hd_wav *w)
{
    free(w->samples);
    memset(w, 0, sizeof *w);
}

int hd_wav_parse(const uint8_t *d, size_t len, const char *name, struct hd_wav *w, char err[HD_ERR_MAX])
{
    memset(w, 0, sizeof *w);
    if (len < 12 || memcmp(d, "RIFF", 4) || memcmp(d + 8, "WAVE", 4)) {
        snprintf(err, HD_ERR_MAX, "%s: not a WAV file (no RIFF/WAVE header)", name);
        return -EINVAL;
    }
    const uint8_t *fmt = NULL, *data = NULL;
    size_t data_len = 0;
    for (size_t at = 12; at + 8 <= len;) {
        const uint64_t size = le32(d + at + 4);
        const uint8_t *body = d + at + 8;
        const size_t room = len - at - 8;
        if (!memcmp(d + at, "fmt ", 4)) {
            if (size < 16 || size > room) {
                snprintf(err, HD_ERR_MAX, "%s: the fmt chunk at byte %zu is cut short", name, at);
                return -EINVAL;
            }
            fmt = body;
            if (le16(fmt) == 0xFFFE && size < 40) {
                snprintf(err, HD_ERR_MAX, "%s: WAVE_FORMAT_EXTENSIBLE fmt chunk of %llu bytes (40 needed)", name,
                         (unsigned long long)size);
                return -EINVAL;
            }
        } else if (!memcmp(d + at, "data", 4)) {
            data = body;
            data_len = size <= room ? (size_t)size : room; /* a header never fixed up: what is there */
            break;
        }
        if (size > room)
            break;
        at += 8 + (size_t)size + (size & 1);
    }
    if (!fmt || !data) {
        snprintf(err, HD_ERR_MAX, "%s: no %s chunk", name, !fmt ? "fmt" : "data");
        return -EINVAL;
    }
    unsigned tag = le16(fmt);
    const unsigned channels = le16(fmt + 2), bits = le16(fmt + 14), align = le16(fmt + 12);
    if (tag == 0xFFFE)
        tag = le16(fmt + 24); /* the sub-format GUID's first two bytes: 1 = PCM */
    if (tag != 1 || (bits != 16 && bits != 24 && bits != 32)) {
        snprintf(err, HD_ERR_MAX, "%s: %s%u-bit samples (format tag %u): only integer PCM of 16, 24 or 32 bits", name,
                 tag == 3 ? "floating-point " : "", bits, tag);
        return -EINVAL;
    }
    if (channels == 0 || channels > HD_MAX_CHANNELS || align != channels * bits / 8) {
        snprintf(err, HD_ERR_MAX, "%s: %u channels of %u bits in %u-byte frames (1..%u channels)", name, channels, bits,
                 align, HD_MAX_CHANNELS);
        return -EINVAL;
    }
    w->channels = channels;
    w->rate_hz = le32(fmt + 4);
    w->bits = bits;
    w->frames = data_len / align;
    if (w->frames == 0) {
        snprintf(err, HD_ERR_MAX, "%s: no frames", name);
        return -EINVAL;
    }
    w->samples = malloc((size_t)w->frames * channels * sizeof *w->samples);
    if (!w->samples) {
        snprintf(err, HD_ERR_MAX, "%s: out of memory for %llu frames", name, (unsigned long long)w->frames);
        return -ENOMEM;
    }
    const size_t n = (size_t)w->frames * channels, step = bits / 8;
    for (size_t i = 0; i < n; i++) {
        const uint8_t *p = data + i * step;
        uint32_t u = bits == 16 ? le16(p) << 16 : bits == 24 ? (le16(p) | (uint32_t)p[2] << 16) << 8 : le32(p);
        w->samples[i] = (int32_t)u;
    }
    return 0;
}

int hd_wav_read(const char *path, struct hd_wav *w, char err[HD_ERR_MAX])
{
    memset(w, 0, sizeof *w);
    /* As board files and tables: opened without blocking (a FIFO at the
     * path would block the open) and refused unless a regular file. */
    int fd;
    haptic_file_status fs;
    const int orc = haptic_file_open_regular(path, HD_WAV_MAX_BYTES, &fd, &fs);
    if (fs.refusal == HAPTIC_FILE_CANNOT_OPEN)
        snprintf(err, HD_ERR_MAX, "%s: cannot open: %s", path, strerror(fs.error));
    else if (fs.refusal == HAPTIC_FILE_NOT_REGULAR)
        snprintf(err, HD_ERR_MAX, "%s: not a regular file (a %s is no WAV file)", path, haptic_file_kind_name(fs.kind));
    else if (fs.refusal == HAPTIC_FILE_TOO_BIG)
        snprintf(err, HD_ERR_MAX, "%s: %lld bytes, larger than the %llu a WAV file may have here", path,
                 (long long)fs.size, HD_WAV_MAX_BYTES);
    if (orc)
        return orc;
    const size_t size = (size_t)fs.size;
    uint8_t *buf = malloc(size + 1);
    size_t got = 0;
    int e = buf ? 0 : ENOMEM;
    while (!e && got < size) {
        ssize_t n = read(fd, buf + got, size - got);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0)
            e = n < 0 ? errno : EIO;
        else
            got += (size_t)n;
    }
    close(fd);
    int rc = e ? -e : hd_wav_parse(buf, got, path, w, err);
    if (e)
        snprintf(err, HD_ERR_MAX, "%s: cannot read: %s", path, strerror(e));
    free(buf);
    return rc;
}

int hd_wav_out_open(struct hd_wav_out *o, const char *path, char err[HD_ERR_MAX])
{
    memset(o, 0, sizeof *o);
    o->fd = -1;
    if (snprintf(o->path, sizeof o->path, "%s", path) >= (int)sizeof o->path ||
        snprintf(o->tmp, sizeof o->tmp, "%s.XXXXXX", path) >= (int)sizeof o->tmp) {
        snprintf(err, HD_ERR_MAX, "%.200s...: path too long", path);
        return -ENAMETOOLONG;
    }
    struct stat st;
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
        snprintf(err, HD_ERR_MAX, "%s: exists and is not a regular file", path);
        return -EINVAL;
    }
    o->fd = mkostemp(o->tmp, O_CLOEXEC);
    if (o->fd < 0) {
        int e = errno;
        snprintf(err, HD_ERR_MAX, "%s: cannot write the recording there: %s", path, strerror(e));
        return -e;
    }
    fchmod(o->fd, 0644);
    return 0;
}

static void put16(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}
static void put32(uint8_t *p, uint32_t v)
{
    put16(p, v & 0xffff);
    put16(p + 2, v >> 16);
}

static int write_all(int fd, const uint8_t *p, size_t n)
{
    while (n > 0) {
        ssize_t w = write(fd, p, n);
        if (w < 0 && errno == EINTR)
            continue;
        if (w < 0)
            return -errno;
        p += w;
        n -= (size_t)w;
    }
    return 0;
}

int hd_wav_out_commit(struct hd_wav_out *o, uint32_t channels, uint32_t rate_hz, unsigned bits, const int32_t *samples,
                      uint64_t frames, char err[HD_ERR_MAX])
{
    const uint64_t bytes = frames * channels * (bits / 8);
    if ((bits != 16 && bits != 32) || bytes > 0xFFFFFFFFull - 36) {
        snprintf(err, HD_ERR_MAX, "%s: %llu frames of %u x %u bits do not fit a WAV file", o->path,
                 (unsigned long long)frames, channels, bits);
        hd_wav_out_abort(o);
        return -EFBIG;
    }
    uint8_t h[44];
    memcpy(h, "RIFF", 4);
    put32(h + 4, (uint32_t)(36 + bytes));
    memcpy(h + 8, "WAVEfmt ", 8);
    put32(h + 16, 16);
    put16(h + 20, 1);
    put16(h + 22, channels);
    put32(h + 24, rate_hz);
    put32(h + 28, rate_hz * channels * (bits / 8));
    put16(h + 32, channels * (bits / 8));
    put16(h + 34, bits);
    memcpy(h + 36, "data", 4);
    put32(h + 40, (uint32_t)bytes);
    int rc = write_all(o->fd, h, sizeof h);
    uint8_t buf[4096];
    const size_t step = bits / 8, n = (size_t)(frames * channels);
    for (size_t i = 0; rc == 0 && i < n;) {
        size_t k = 0;
        for (; i < n && k + step <= sizeof buf; i++, k += step) {
            const uint32_t u = (uint32_t)samples[i];
            if (bits == 16)
                put16(buf + k, u >> 16);
            else
                put32(buf + k, u);
        }
        rc = write_all(o->fd, buf, k);
    }
    if (rc == 0 && fsync(o->fd) != 0)
        rc = -errno;
    if (rc == 0) {
        rc = close(o->fd) != 0 ? -errno : 0;
        o->fd = -1;
    }
    if (rc == 0 && rename(o->tmp, o->path) != 0)
        rc = -errno;
    if (rc != 0) {
        snprintf(err, HD_ERR_MAX, "%s: writing the recording failed: %s (nothing written there)", o->path,
                 strerror(-rc));
        hd_wav_out_abort(o);
        return rc;
    }
    o->tmp[0] = '\0';
    return 0;
}

void hd_wav_out_abort(struct hd_wav_out *o)
{
    if (o->fd >= 0)
        close(o->fd);
    o->fd = -1;
    if (o->tmp[0])
        unlink(o->tmp);
    o->tmp[0] = '\0';
}
