/* player.h - the per-period render: which voices play and how triggers start them.
 *
 * Policy for a trigger during playback: ADD. Every trigger starts a new voice
 * at the frame the player renders next (the next period boundary, or the
 * frame a rewind went back to); voices already playing continue to their end
 * untouched (cutting a voice would click, and its focus would be lost).
 * Triggers that arrive before the same start are merged into ONE voice whose
 * foci are the union of theirs (several fingers at once), with one
 * energy-normalized gain for the union. Overlapping voices add; their sum
 * saturates (counted in clipped_samples) instead of wrapping around.
 * At most HD_MAX_VOICES play at once: a new voice takes the place of the
 * oldest one (counted in voices_stolen), so the newest touch always answers.
 *
 * Voices are placed on the device timeline (absolute frames), so rendering
 * is a pure function of the voices and the frame range: after a rewind the
 * player renders the same frames again, identical except for the voices
 * started since. A voice's slot is kept until no rewind can reach it
 * (`committed`), so a rewind never loses the tail of a voice that ended.
 */
#ifndef HD_PLAYER_H
#define HD_PLAYER_H

#include "mixer.h"
#include "protect.h"

#include <stdatomic.h>
#include <stdint.h>

#define HD_MAX_VOICES 8u

struct hd_voice {
    const struct hd_program *program; /* NULL: slot free */
    struct hd_mix mix;
    uint64_t start; /* device frame of its first sample */
};

struct hd_player_stats {
    uint64_t voices_started, voices_stolen, clipped_samples, unknown_foci, dropped_foci;
    uint64_t policy_foci; /* foci left out by [mixer] max_foci */
};

struct hd_player {
    struct hd_voice voices[HD_MAX_VOICES];
    uint32_t frames_max; /* period size the scratch buffer holds */
    uint32_t channels;   /* device channels */
    enum hd_sample_format format;
    uint32_t map_count;
    uint32_t channel_map[HD_MAX_CHANNELS];
    double gain_limit;
    _Atomic uint64_t level_bits;     /* the user's intensity, linear, as a double's bits (hd_player_set_level) */
    uint32_t max_foci;               /* [mixer] max_foci */
    enum hd_foci_policy foci_policy; /* which foci play when a voice asks for more */
    uint32_t rate_hz;
    struct hd_protect protect; /* the exciters' ratings (protect.h) */
    int protected;             /* the board has [exciters]: every voice is admitted by `protect` */
    int64_t *acc;              /* [frames_max][channels], allocated once at init */
    uint64_t frame;            /* next device frame render writes */
    uint64_t committed;        /* frames before this are never rendered again */
    uint32_t rewind_window;    /* how far behind `frame` a rewind may go (0: never) */
    struct hd_player_stats stats;
};

int hd_player_init(struct hd_player *pl, const struct hd_board *b);

/* The user's intensity, linear (1 = the table's level), for the voices
 * started from now on; any thread, lock-free. */
void hd_player_set_level(struct hd_player *pl, double level);
double hd_player_level(const struct hd_player *pl);
void hd_player_free(struct hd_player *pl);

/* Start one voice playing the union of the given focus ids (resolved in p;
 * unknown ids are skipped and counted). With a table that gives each focus's
 * safe range (format 1.3) the user's level is clamped into the intersection
 * of the voice's foci's ranges (hd_mixer_gain_in_range). On a board with
 * [exciters] ratings the voice is admitted by the coils' heat (protect.h;
 * the device timeline's frame is the clock): played at its gain, lowered,
 * or skipped, and skipped rather than lowered below the bottom of its safe
 * range. Returns 1 if a voice started, 0 if nothing was playable or
 * protection skipped it. Real-time safe. */
int hd_player_start(struct hd_player *pl, const struct hd_program *p, const uint32_t *ids, uint32_t count);

/* Start a voice from a precomputed mix (tests, benchmarks). */
void hd_player_start_mix(struct hd_player *pl, const struct hd_program *p, const struct hd_mix *m);

/* Render `frames` (<= frames_max) interleaved frames in the device format into
 * out: device frames [frame, frame + frames); then frame += frames. */
void hd_player_render(struct hd_player *pl, void *out, uint32_t frames);

/* Place the timeline: the next frame to render is `frame` (the frames before
 * it are silence), and rewinds may go back at most `window` frames behind the
 * render position. */
void hd_player_set_timeline(struct hd_player *pl, uint64_t frame, uint32_t window);

/* Frames a rewind may go back now: frame - committed. */
uint64_t hd_player_rewindable(const struct hd_player *pl);

/* Go back `frames` frames (at most hd_player_rewindable) so they are
 * rendered again. Returns the frames gone back. */
uint64_t hd_player_rewind(struct hd_player *pl, uint64_t frames);

/* Number of voices with frames still to render; and whether any voice a
 * render may still need plays from program p. */
uint32_t hd_player_active(const struct hd_player *pl);
int hd_player_uses(const struct hd_player *pl, const struct hd_program *p);

#endif
