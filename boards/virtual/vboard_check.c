/* vboard_check.c - the synthetic table and the comparison of a recorded
 * voice with it. The reference is recomputed here from the table's raw
 * samples in double precision (not with hapticd's code): one focus plays
 * exactly as stored (S32 = sample * 2^16); K foci at once play
 * g * sum_f s_f with g = sqrt(E_ref / E_sum), E_ref the mean energy of the
 * foci alone and E_sum the energy of their plain sum (docs/firmware.md). */
#define _GNU_SOURCE
#include "vboard.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static unsigned failed;

void vb_result(int ok, const char *name, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    printf("vboard: %s %s: ", ok ? "PASS" : "FAIL", name);
    vprintf(fmt, ap);
    printf("\n");
    fflush(stdout);
    va_end(ap);
    failed += !ok;
}

unsigned vb_failed(void) { return failed; }

int vb_make_table(const char *path)
{
    const uint16_t channels = 8;
    int16_t *s = calloc((size_t)VB_FOCI * VB_SAMPLES * channels, sizeof *s);
    if (!s)
        return -1;
    uint32_t x = 2463534242u; /* xorshift32: reproducible, no libc rand() */
    for (size_t i = 0; i < (size_t)VB_FOCI * VB_SAMPLES * channels; i++) {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        s[i] = (int16_t)((int)(x % (2u * VB_AMPLITUDE + 1)) - VB_AMPLITUDE);
    }
    /* Every signal starts with a full-scale frame, so its first sample marks
     * the voice start in the recording. */
    for (uint32_t f = 0; f < VB_FOCI; f++)
        s[(size_t)f * VB_SAMPLES * channels] = VB_AMPLITUDE;
    double channel_xy[16], focus_xy[2 * VB_FOCI], scale[VB_FOCI];
    uint32_t ids[VB_FOCI];
    for (unsigned c = 0; c < channels; c++) { /* exciters around a 0.2 m x 0.15 m panel */
        channel_xy[2 * c] = c < 4 ? 0.01 + 0.06 * c : 0.01 + 0.06 * (c - 4);
        channel_xy[2 * c + 1] = c < 4 ? 0.005 : 0.145;
    }
    for (uint32_t f = 0; f < VB_FOCI; f++) { /* foci on a 2 x 2 grid */
        ids[f] = f;
        focus_xy[2 * f] = f % 2 ? 0.15 : 0.05;
        focus_xy[2 * f + 1] = f / 2 ? 0.1125 : 0.0375;
        scale[f] = 1e-6;
    }
    haptic_table_spec spec = {
        .sample_rate_hz = 48000,
        .channel_count = channels,
        .focus_count = VB_FOCI,
        .samples_per_signal = VB_SAMPLES,
        .channel_xy_m = channel_xy,
        .focus_id = ids,
        .focus_xy_m = focus_xy,
        .focus_scale_m = scale,
        .samples = s,
        .scene_name = "virtual-board",
        .tool_version = "vboard-driver",
    };
    haptic_table_error err;
    int rc = haptic_table_write(path, &spec, &err);
    if (rc)
        fprintf(stderr, "vboard: %s: %s\n", path, err.message);
    free(s);
    return rc;
}

/* Plain sum of the voice's foci at frame n, channel c (counts). */
static double voice_sum(const haptic_table *t, const struct vb_expect *e, uint32_t n, uint32_t c)
{
    double s = 0;
    for (unsigned k = 0; k < e->count; k++)
        s += haptic_table_signal(t, e->index[k])[(size_t)n * t->channel_count + c];
    return s;
}

static double reference_gain(const haptic_table *t, const struct vb_expect *e, double *e_ref)
{
    double ref = 0, sum = 0;
    for (uint32_t n = 0; n < t->samples_per_signal; n++)
        for (uint32_t c = 0; c < t->channel_count; c++) {
            for (unsigned k = 0; k < e->count; k++) {
                double v = haptic_table_signal(t, e->index[k])[(size_t)n * t->channel_count + c];
                ref += v * v / e->count;
            }
            double s = voice_sum(t, e, n, c);
            sum += s * s;
        }
    *e_ref = ref;
    return e->count == 1 ? 1.0 : sqrt(ref / sum);
}

static int expected_silent(const haptic_table *t, const struct vb_expect *e, uint32_t n)
{
    for (uint32_t c = 0; c < t->channel_count; c++)
        if (voice_sum(t, e, n, c) != 0)
            return 0;
    return 1;
}

static int frame_silent(const int32_t *f, unsigned channels)
{
    for (unsigned c = 0; c < channels; c++)
        if (f[c])
            return 0;
    return 1;
}

/* At an underrun the driver's position runs past the last frame written by
 * up to one timer tick; without ALSA's silence fill the ring buffer's old
 * contents would play there: the frames written one buffer earlier.
 * Recognized exactly, so that they can be named (and fail the check). */
static int frame_stale(const struct vb_capture *cap, size_t i, size_t buffer_frames)
{
    const unsigned C = cap->channels;
    if (!buffer_frames || i < buffer_frames || frame_silent(cap->frames + i * C, C))
        return 0;
    return !memcmp(cap->frames + i * C, cap->frames + (i - buffer_frames) * C, C * sizeof *cap->frames);
}

void vb_check_voice(const struct vb_capture *cap, const haptic_table *t, struct vb_expect *e, uint64_t until_ns,
                    size_t underrun_frames)
{
    const unsigned C = cap->channels;
    const uint32_t N = t->samples_per_signal;
    size_t from, to;
    /* A voice cannot start before its trigger; the capture clock's estimate
     * may run up to one timer tick (4 ms at HZ=250) early, so look from 5 ms before. */
    const struct vb_segment *seg = vb_capture_at(cap, e->t_ns - 5000000u, &from);
    if (!seg) {
        vb_result(0, e->name, "no recording at the trigger time");
        return;
    }
    if (!until_ns || !vb_capture_at(cap, until_ns, &to))
        to = atomic_load(&cap->count);
    size_t onset = from;
    while (onset < to && frame_silent(cap->frames + onset * C, C))
        onset++;
    if (onset == to) {
        vb_result(0, e->name, "silence from %.1f ms before the trigger to the next one", 5.0);
        return;
    }
    uint32_t first = 0; /* first frame of the voice that is not silent */
    while (first < N && expected_silent(t, e, first))
        first++;
    size_t start = onset - first;
    if (onset < first || isnan(vb_capture_time_ns(cap, start, 0))) {
        vb_result(0, e->name, "the voice at capture frame %zu starts before the recording", onset);
        return;
    }
    double e_ref, g = reference_gain(t, e, &e_ref);
    uint64_t mismatched = 0;
    double max_err = 0, e_mix = 0, num = 0, den = 0;
    size_t pos = start, gap_frames = 0, stale = 0;
    uint32_t gap_at = 0;
    uint32_t n = 0;
    for (; n < N && pos < to; n++, pos++) {
        /* hapticd recovers an underrun (it was stalled longer than its
         * buffer: emulation does that on a loaded host) by priming the
         * buffer with silence, and the voice goes on after it: one such gap
         * is allowed, and named. */
        if (!gap_frames && !expected_silent(t, e, n) &&
            (frame_silent(cap->frames + pos * C, C) || frame_stale(cap, pos, underrun_frames))) {
            gap_at = n;
            size_t gap_start = pos;
            for (; pos < to && (frame_silent(cap->frames + pos * C, C) || frame_stale(cap, pos, underrun_frames));
                 pos++) {
                gap_frames++;
                stale += frame_stale(cap, pos, underrun_frames);
            }
            if (pos == to)
                break;
            if (gap_frames < underrun_frames) { /* not an underrun's: compare the silence */
                pos = gap_start;
                gap_frames = (size_t)-1;
                stale = 0;
            }
        }
        for (uint32_t c = 0; c < C; c++) {
            double sum = c < t->channel_count ? voice_sum(t, e, n, c) : 0;
            double got = cap->frames[pos * C + c], want = g * sum * 65536.0;
            /* S32 from the Q30 gain: within 1 LSB plus the gain's quantization. */
            double tol = e->count == 1 ? 0 : 1.0 + fabs(sum) / 32768.0;
            double err = fabs(got - want);
            mismatched += err > tol;
            max_err = fmax(max_err, err);
            e_mix += (got / 65536.0) * (got / 65536.0);
            num += got * sum;
            den += sum * sum * 65536.0;
        }
    }
    size_t tail = pos + cap->rate_hz / 10;
    if (n < N && gap_frames && gap_frames != (size_t)-1) { /* a gap ran to the next trigger */
        vb_result(0, e->name,
                  "the voice at capture frame %zu stops after its frame %u (%llu samples off before): silence for "
                  "the %zu frames to the next trigger (or the end of the recording)",
                  onset, gap_at, (unsigned long long)mismatched, gap_frames);
        return;
    }
    if (n < N || tail > to || (seg + 1 < cap->segments + atomic_load(&cap->segment_count) && tail > (seg + 1)->start)) {
        int by_overrun = !(n < N || tail > to);
        vb_result(0, e->name,
                  "the voice at capture frame %zu is cut after its frame %u: %s at capture frame %zu, before the "
                  "100 ms after the voice (to frame %zu) are recorded; %zu frames of silence after its frame %u",
                  onset, n, by_overrun ? "a capture overrun" : "the next trigger or the end of the recording",
                  by_overrun ? (seg + 1)->start : to, tail, gap_frames == (size_t)-1 ? 0 : gap_frames, gap_at);
        return;
    }
    uint64_t stray = 0;
    size_t first_stray = 0;
    for (size_t i = pos; i < tail; i++) {
        if (frame_stale(cap, i, underrun_frames))
            stale++;
        else if (!frame_silent(cap->frames + i * C, C) && !stray++)
            first_stray = i;
    }
    /* Something played after the voice: say which focus it starts like. */
    char stray_text[96] = "";
    if (stray) {
        int match = -1;
        for (uint32_t f = 0; f < t->focus_count && match < 0; f++) {
            const int16_t *sig = haptic_table_signal(t, f);
            int same = 1;
            for (uint32_t c = 0; c < C && c < t->channel_count; c++)
                same &= cap->frames[first_stray * C + c] == (int32_t)sig[c] * 65536;
            if (same)
                match = (int)f;
        }
        snprintf(stray_text, sizeof stray_text, " (from %.1f ms after the voice start%s%d)",
                 1e3 * (double)(first_stray - start) / cap->rate_hz,
                 match >= 0 ? ", focus index " : ", no focus alone: ", match);
    }
    e->found = 1;
    e->latency_s = (vb_capture_time_ns(cap, start, 1) - (double)e->t_ns) / 1e9;
    double energy_rel = fabs(e_mix - e_ref) / e_ref;
    char gap_text[160] = "";
    if (gap_frames == (size_t)-1)
        gap_frames = 0;
    int n_text = 0;
    if (gap_frames)
        n_text = snprintf(gap_text, sizeof gap_text, " (an underrun's %zu frames of silence after its frame %u)",
                          gap_frames, gap_at);
    if (stale)
        snprintf(gap_text + n_text, sizeof gap_text - (size_t)n_text,
                 " (%zu stale frames at an underrun: the frames of one buffer earlier)", stale);
    /* hapticd has ALSA zero what has been played, so an underrun plays
     * silence: a stale frame is a defect. */
    int ok = mismatched == 0 && stray == 0 && stale == 0 && energy_rel < 1e-3;
    vb_result(ok, e->name,
              "%u frames x %u ch at capture frame %zu%s: %llu samples off (max error %.0f LSB), "
              "gain %.6f (reference %.6f), mix energy / E_ref - 1 = %.1e, %llu non-silent frames after%s; "
              "voice start on the capture %.2f ms after the trigger",
              N, C, start, gap_text, (unsigned long long)mismatched, max_err, num / den, g, (e_mix - e_ref) / e_ref,
              (unsigned long long)stray, stray_text, e->latency_s * 1e3);
}
