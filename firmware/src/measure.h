/* measure.h - hapticd --measure PLAN.wav --capture REC.wav: the bench step.
 *
 * A separate mode of the program (the real-time daemon is not involved):
 * the plan, one channel per exciter at the board's rate, plays through the
 * path tables take (the board's channel map and device format; the plan's
 * samples are the drive, full scale = a table's full scale) while the
 * board's [capture] device records; the recording is written so that its
 * sample 0 is the plan's sample 0.
 *
 * Alignment. With device pacing the capture PCM is linked to the playback
 * (snd_pcm_link: one card, started by one trigger), the playback is
 * pre-filled with P0 frames of silence (its buffer), and the stream starts
 * when the pre-fill is queued, so capture frame i is taken when playback
 * frame i leaves the buffer; plan frame j is playback frame P0 + j, and the
 * recording is capture frames P0 + offset + j, with `offset` the board's
 * [capture] offset_frames (the converters' own fixed lag, measured once
 * with a loopback; 0 for a digital loopback). With clock pacing (plugins
 * that keep no time, host-sim) the device is emulated: capture frame i is
 * read once playback frame i + buffer has been written (what a device with
 * that buffer would have played by then), the same timeline.
 *
 * Nothing is altered to make a plan fit: a plan whose rate, channel count
 * or sample width the board does not play, whose peak exceeds [mixer]
 * gain_limit, or whose power would heat an exciter beyond its [exciters]
 * rating (protect.h's first-order model, computed over the whole plan) is
 * refused in one line. The user's intensity file is not applied. */
#ifndef HD_MEASURE_H
#define HD_MEASURE_H

#include "board.h"
#include "hd_defs.h"
#include "wav.h"

#include <stdint.h>

/* The plan against the board: rate, one channel per exciter
 * ([alsa] channel_map), samples the device format holds exactly, peak
 * within [mixer] gain_limit. 0, or -EINVAL with one line naming both files. */
int hd_measure_check_plan(const struct hd_wav *plan, const char *plan_path, const struct hd_board *b,
                          char err[HD_ERR_MAX]);

/* The exciters' heat over the plan (protect.h), each exciter on its device
 * channel. 1: within the ratings, the hottest exciter's peak heat and
 * rating in *heat_w, *rated_w, its index in *exciter; 0: the board has no
 * ratings; -EINVAL: over a rating, one line in err. */
int hd_measure_check_power(const struct hd_wav *plan, const char *plan_path, const struct hd_board *b, double *heat_w,
                           double *rated_w, unsigned *exciter, char err[HD_ERR_MAX]);

/* Device frames [from, from + frames) of the playback timeline in which
 * plan frame j is device frame `lead` + j (silence outside the plan), in
 * the board's format and channel map, into out. */
void hd_measure_render(const struct hd_wav *plan, const struct hd_board *b, uint64_t lead, uint64_t from,
                       uint32_t frames, void *out);

/* The whole mode; returns the exit status (0, or 1 with one line logged). */
int hd_measure_run(const struct hd_board *b, const char *plan_path, const char *rec_path, const char *alsa_device);

#endif
