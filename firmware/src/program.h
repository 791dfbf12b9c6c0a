/* program.h - a loaded table plus what the real-time path needs from it,
 * precomputed once at load (never on the real-time path): the focus id ->
 * index lookup, the block-peak envelope used by the peak limit, each focus's
 * safe gain range (format 1.3), and, on a panel faster or slower than the
 * calibrated plate, the drives stretched by the speed ratio (panel.h) with
 * their own Gram matrix. */
#ifndef HD_PROGRAM_H
#define HD_PROGRAM_H

#include "hd_defs.h"
#include "board.h"

#include <haptic_mix.h>
#include <haptic_table.h>
#include <stddef.h>
#include <stdint.h>

#define HD_PEAK_BLOCK HAPTIC_MIX_PEAK_BLOCK /* frames per block of the peak envelope (haptic_mix.h) */

struct hd_focus_key {
    uint32_t id;
    uint32_t index;
};

struct hd_program {
    haptic_table table;
    uint32_t focus_count, channel_count, samples;
    struct hd_focus_key *by_id; /* sorted by id */
    uint32_t blocks;            /* ceil(samples / HD_PEAK_BLOCK) */
    uint16_t *block_peak;       /* [focus][block][channel]: max |s| in that block (<= 32768) */
    double *root_energy;        /* [focus][channel]: sqrt(sum_n s[n][c]^2), the exciters' heat (protect.h) */
    haptic_gain_range *range;   /* [focus]: the gains it passes the verdict at (1.3); NULL: the table has none.
                                    A stretch keeps them: they hold for the drives as the plate receives them */
    double speed_ratio;         /* the drives play this many times as fast as stored (1: as stored) */
    int16_t *stretched;         /* [focus][n][c], `samples` frames; NULL at speed ratio 1 */
    double *gram;               /* [focus][focus] of `stretched`; NULL at speed ratio 1 */
    uint64_t stretch_clipped;   /* samples the stretch saturated */
    char path[HD_PATH_MAX];
};

/* Open and validate a table file, check it against the board (rate, channel
 * count = channel_map length), precompute. One-line error in err. */
int hd_program_load(const char *path, const struct hd_board *b, struct hd_program **out, char err[HD_ERR_MAX]);

/* A new program of the same table as `src` (its own copy of the file
 * bytes, already validated), not stretched: what a temperature step
 * stretches again without reading the file. */
int hd_program_clone(const struct hd_program *src, const struct hd_board *b, struct hd_program **out,
                     char err[HD_ERR_MAX]);

/* Same from a table already validated in memory (tests, benchmarks); the
 * program takes ownership of nothing: the caller keeps `data` alive. */
int hd_program_from_table(const haptic_table *t, const struct hd_board *b, struct hd_program **out,
                          char err[HD_ERR_MAX]);

/* Plays the table `speed_ratio` times as fast (panel.h): stretches every
 * drive (common/haptic_stretch.h), computes their Gram matrix exactly and
 * the peak envelope again. Before the program is handed to the engine, once.
 * 0; or -EINVAL (a ratio outside the range, a program stretched already),
 * -E2BIG (more than HD_STRETCH_MAX_PRODUCTS for the Gram matrix), -ENOMEM or
 * -EIO (the resampler), with a one-line message, the program then playing the
 * table as stored. */
#define HD_STRETCH_MAX_PRODUCTS ((uint64_t)1 << 34) /* ~1.7e10: seconds on the main thread, not minutes */
int hd_program_set_speed(struct hd_program *p, double speed_ratio, char err[HD_ERR_MAX]);

void hd_program_free(struct hd_program *p);

/* The table's lead time: seconds from a voice's first sample to its focal
 * peak (the end of the kept time-reversal window), the largest over the
 * table's foci, over the speed ratio; NAN when the table does not say. */
double hd_program_lead_time_s(const struct hd_program *p);

/* The safe range of the foci index[0..count) played together, the
 * intersection of theirs (haptic_gain_range_intersect): 1 and *out, or 0
 * when the table has none (the gain is then not clamped). Real-time safe. */
int hd_program_voice_range(const struct hd_program *p, const uint32_t *index, uint32_t count, haptic_gain_range *out);

/* What the clamp does to the foci played alone at the user's `level`
 * (linear; alone, a focus's gain is the level: haptic_mix.h), in one line
 * for the log: "intensity +8.0 dB: above the safe range of 5 of 9 foci (tops
 * -1.2..+6.3 dB): they play at their tops", the foci below likewise, the
 * foci that fail at every gain named apart. The number of foci the clamp
 * moves, 0 (and an empty line) when every focus is inside its range or the
 * table has no range section. Main thread. */
int hd_program_range_note(const struct hd_program *p, double level, char *out, size_t cap);

/* Index of the focus with this id, or -1 (binary search, real-time safe). */
int32_t hd_program_find(const struct hd_program *p, uint32_t id);

static inline const int16_t *hd_program_signal(const struct hd_program *p, uint32_t index)
{
    return p->stretched ? p->stretched + (size_t)index * p->samples * p->channel_count
                        : haptic_table_signal(&p->table, index);
}

/* Gram[i][j] of the drives as played (indices checked by the caller). */
static inline double hd_program_gram(const struct hd_program *p, uint32_t i, uint32_t j)
{
    return p->gram ? p->gram[(size_t)i * p->focus_count + j] : haptic_table_gram(&p->table, i, j);
}

#endif
