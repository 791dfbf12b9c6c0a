/* wav.h - the WAV files of the bench step (hapticd --measure): the plan
 * read whole, the recording written atomically. hapticd has no other WAV
 * code (on host-sim the ALSA "file" plugin writes the played WAV; libsndfile
 * is a test dependency only), so this is the one reader and writer.
 *
 * Read: RIFF/WAVE, integer PCM of 16, 24 or 32 bits (format tag 1, or
 * WAVE_FORMAT_EXTENSIBLE with the PCM sub-format), any chunk order, unknown
 * chunks skipped. Samples come back as int32 at 32-bit scale (a 16-bit
 * sample x is x * 65536), interleaved. The file is opened without blocking
 * and refused unless it is a regular file (as board files and tables are),
 * and bounded before anything is allocated. Errors: one line naming the file.
 *
 * Write: 16- or 32-bit PCM (format tag 1, the header libsndfile and the
 * ALSA file plugin write), into a temporary file next to the destination
 * that is renamed over it once complete and flushed: a reader never sees a
 * half-written recording, and a failure leaves nothing behind. */
#ifndef HD_WAV_H
#define HD_WAV_H

#include "hd_defs.h"

#include <stddef.h>
#include <stdint.h>

#define HD_WAV_MAX_BYTES (2048ull * 1024u * 1024u) /* 2 GiB: 46 min of 8 x 16 bit at 48 kHz */

struct hd_wav {
    uint32_t channels, rate_hz;
    unsigned bits; /* 16, 24 or 32 as stored */
    uint64_t frames;
    int32_t *samples; /* frames * channels, 32-bit scale */
};

/* Read a WAV file whole. Returns 0, or a negative errno with one line in err. */
int hd_wav_read(const char *path, struct hd_wav *w, char err[HD_ERR_MAX]);
/* Parse a WAV held in memory (`name` for messages). */
int hd_wav_parse(const uint8_t *data, size_t len, const char *name, struct hd_wav *w, char err[HD_ERR_MAX]);
void hd_wav_free(struct hd_wav *w);

/* A recording on its way to `path`. */
struct hd_wav_out {
    char path[HD_PATH_MAX];
    char tmp[HD_PATH_MAX + 16];
    int fd; /* the temporary file, -1 when none */
};

/* Create the temporary file next to `path` (PATH.XXXXXX, mode 0644): a
 * path that cannot be written is found here, before anything plays. */
int hd_wav_out_open(struct hd_wav_out *o, const char *path, char err[HD_ERR_MAX]);
/* Write the header and `frames` interleaved frames (int32 at 32-bit scale,
 * stored as `bits` = 16 or 32: 16 keeps the top half, exact for samples
 * that came from a 16-bit device), fsync, rename over the destination. On
 * failure the temporary file is removed and err says why. */
int hd_wav_out_commit(struct hd_wav_out *o, uint32_t channels, uint32_t rate_hz, unsigned bits, const int32_t *samples,
                      uint64_t frames, char err[HD_ERR_MAX]);
/* Give up: remove the temporary file (nothing at the destination changes). */
void hd_wav_out_abort(struct hd_wav_out *o);

#endif
