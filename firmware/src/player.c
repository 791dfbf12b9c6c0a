/* player.c - voices and the render loop (real-time path: no allocation
 * after init, no lock, no I/O). */
#include "player.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

int hd_player_init(struct hd_player *pl, const struct hd_board *b)
{
    memset(pl, 0, sizeof *pl);
    pl->frames_max = b->period_frames;
    pl->channels = b->channels;
    pl->format = b->format;
    pl->map_count = b->map_count;
    memcpy(pl->channel_map, b->channel_map, sizeof pl->channel_map);
    pl->gain_limit = b->gain_limit;
    hd_player_set_level(pl, 1.0);
    pl->rate_hz = b->rate_hz;
    pl->max_foci = b->max_foci;
    pl->foci_policy = b->foci_policy;
    struct hd_exciter_rating rating[HD_MAX_CHANNELS], on_device[HD_MAX_CHANNELS];
    if (hd_board_exciter_ratings(b, rating, b->map_count)) {
        /* Exciter k (the table's channel k) is wired to device channel map[k]. */
        memset(on_device, 0, sizeof on_device);
        for (uint32_t k = 0; k < b->map_count; k++)
            on_device[b->channel_map[k]] = rating[k];
        if (hd_protect_init(&pl->protect, b->channels, on_device, b->amp_full_scale_v, b->rate_hz) != 0)
            return -EINVAL;
        pl->protected = 1;
    }
    pl->acc = calloc((size_t)pl->frames_max * pl->channels, sizeof *pl->acc);
    return pl->acc ? 0 : -ENOMEM;
}

void hd_player_set_level(struct hd_player *pl, double level)
{
    uint64_t bits;
    memcpy(&bits, &level, sizeof bits);
    atomic_store_explicit(&pl->level_bits, bits, memory_order_relaxed);
}

double hd_player_level(const struct hd_player *pl)
{
    uint64_t bits = atomic_load_explicit(&((struct hd_player *)pl)->level_bits, memory_order_relaxed);
    double level;
    memcpy(&level, &bits, sizeof level);
    return level;
}

void hd_player_free(struct hd_player *pl)
{
    free(pl->acc);
    pl->acc = NULL;
}

static uint64_t voice_end(const struct hd_voice *v) { return v->start + v->program->samples; }

/* A slot for a voice starting at pl->frame. Free: unused, or its voice lies
 * wholly before `committed`. Else, without loss, the voice that ended first
 * (rendered to its end, its tail only still within a rewind's reach). Else
 * the oldest playing voice is cut (stolen). Reusing a slot whose voice a
 * rewind could still need moves `committed` up to the start of the new voice,
 * so no later rewind re-renders frames without it. */
static struct hd_voice *take_slot(struct hd_player *pl)
{
    struct hd_voice *ended = NULL, *oldest = NULL;
    for (unsigned i = 0; i < HD_MAX_VOICES; i++) {
        struct hd_voice *v = &pl->voices[i];
        if (!v->program || voice_end(v) <= pl->committed)
            return v;
        if (voice_end(v) <= pl->frame) {
            if (!ended || voice_end(v) < voice_end(ended))
                ended = v;
        } else if (!oldest || v->start < oldest->start) {
            oldest = v;
        }
    }
    struct hd_voice *v = ended ? ended : oldest;
    if (!ended)
        pl->stats.voices_stolen++;
    pl->committed = pl->frame;
    return v;
}

void hd_player_start_mix(struct hd_player *pl, const struct hd_program *p, const struct hd_mix *m)
{
    struct hd_voice *v = take_slot(pl);
    v->program = p;
    v->mix = *m;
    v->start = pl->frame;
    pl->stats.voices_started++;
}

static uint64_t device_ns(const struct hd_player *pl, uint64_t frame)
{
    return (uint64_t)((double)frame * 1e9 / pl->rate_hz);
}

/* sum_k gain sqrt(E_k,c) of a mix, added per device channel into root. */
static void add_root(const struct hd_player *pl, const struct hd_program *p, const struct hd_mix *m, double gain,
                     double *root)
{
    const uint32_t C = p->channel_count;
    for (uint32_t k = 0; k < m->count; k++)
        for (uint32_t c = 0; c < C; c++)
            root[pl->channel_map[c]] += gain * p->root_energy[(size_t)m->index[k] * C + c];
}

/* The coils' heat admits the voice at its gain, lowers it, or skips it
 * (0): the heat measured so far, and the energy still to come from the
 * voices playing and this one (protect.h). Lowered below `min_gain` (the
 * bottom of the voice's safe range: its foci would not be felt), it is
 * skipped. */
static int admit(struct hd_player *pl, const struct hd_program *p, struct hd_mix *m, double min_gain)
{
    double playing[HD_MAX_CHANNELS] = {0}, fresh[HD_MAX_CHANNELS] = {0};
    for (unsigned i = 0; i < HD_MAX_VOICES; i++) {
        const struct hd_voice *v = &pl->voices[i];
        if (v->program && voice_end(v) > pl->frame)
            add_root(pl, v->program, &v->mix, v->mix.gain, playing);
    }
    add_root(pl, p, m, 1.0, fresh);
    const double g = hd_protect_admit(&pl->protect, device_ns(pl, pl->frame), playing, fresh, m->gain, min_gain);
    if (g <= 0.0)
        return 0;
    if (g < m->gain) {
        m->gain = g;
        m->gain_q30 = haptic_mix_q30(g);
    }
    return 1;
}

int hd_player_start(struct hd_player *pl, const struct hd_program *p, const uint32_t *ids, uint32_t count)
{
    struct hd_mix m;
    m.count = 0;
    for (uint32_t i = 0; i < count; i++) {
        int32_t idx = hd_program_find(p, ids[i]);
        if (idx < 0) {
            pl->stats.unknown_foci++;
            continue;
        }
        uint32_t k;
        for (k = 0; k < m.count; k++)
            if (m.index[k] == (uint32_t)idx)
                break;
        if (k < m.count)
            continue; /* union: a focus twice is played once */
        if (m.count == HD_MAX_VOICE_FOCI) {
            pl->stats.dropped_foci++;
            continue;
        }
        m.index[m.count++] = (uint32_t)idx;
    }
    if (m.count > pl->max_foci) {
        /* More fingers than the board plays at once: the newest (the end of
         * the union, in arrival order) or the first. */
        const uint32_t drop = m.count - pl->max_foci;
        if (pl->foci_policy == HD_FOCI_NEWEST)
            memmove(m.index, m.index + drop, pl->max_foci * sizeof m.index[0]);
        m.count = pl->max_foci;
        pl->stats.policy_foci += drop;
    }
    /* A table with safe ranges (1.3): the voice's gain is clamped into the
     * intersection of its foci's, and that range's bottom is the floor the
     * exciters' protection may not lower it below. */
    haptic_gain_range range;
    const int ranged = hd_program_voice_range(p, m.index, m.count, &range);
    if (m.count == 0 || hd_mixer_gain_in_range(p, hd_player_level(pl), ranged ? &range : NULL, pl->gain_limit, &m))
        return 0;
    if (pl->protected && !admit(pl, p, &m, ranged ? haptic_gain_range_clamp(&range, 0.0) : 0.0))
        return 0;
    hd_player_start_mix(pl, p, &m);
    return 1;
}

/* The voice's samples for device frames [lo, hi), added into the scratch rows from `row0`. */
static void render_voice(struct hd_player *pl, const struct hd_voice *v, uint64_t lo, uint64_t hi, int64_t *row0)
{
    const struct hd_program *p = v->program;
    const uint32_t C = p->channel_count, K = v->mix.count, chs = pl->channels;
    const uint32_t n = (uint32_t)(hi - lo), position = (uint32_t)(lo - v->start);
    const int16_t *sig[HD_MAX_VOICE_FOCI];
    for (uint32_t k = 0; k < K; k++)
        sig[k] = hd_program_signal(p, v->mix.index[k]) + (size_t)position * C;
    const int64_t g = v->mix.gain_q30;
    for (uint32_t i = 0; i < n; i++) {
        int64_t *row = row0 + (size_t)i * chs;
        for (uint32_t c = 0; c < C; c++) {
            int32_t s = 0; /* exact: |sum| <= 32 * 32768 */
            for (uint32_t k = 0; k < K; k++)
                s += sig[k][(size_t)i * C + c];
            row[pl->channel_map[c]] += (int64_t)s * g;
        }
    }
}

void hd_player_render(struct hd_player *pl, void *out, uint32_t frames)
{
    const uint32_t n = frames * pl->channels;
    const uint64_t f0 = pl->frame, f1 = f0 + frames;
    memset(pl->acc, 0, (size_t)n * sizeof *pl->acc);
    for (unsigned i = 0; i < HD_MAX_VOICES; i++) {
        const struct hd_voice *v = &pl->voices[i];
        if (!v->program)
            continue;
        uint64_t lo = v->start > f0 ? v->start : f0, end = voice_end(v), hi = end < f1 ? end : f1;
        if (lo < hi)
            render_voice(pl, v, lo, hi, pl->acc + (size_t)(lo - f0) * pl->channels);
    }
    if (pl->protected)
        hd_protect_played(&pl->protect, pl->acc, frames, pl->channels, device_ns(pl, f1));
    pl->stats.clipped_samples +=
        pl->format == HD_FMT_S16_LE ? haptic_mix_to_s16(pl->acc, out, n) : haptic_mix_to_s32(pl->acc, out, n);
    pl->frame = f1;
    if (f1 > pl->rewind_window && f1 - pl->rewind_window > pl->committed)
        pl->committed = f1 - pl->rewind_window;
    for (unsigned i = 0; i < HD_MAX_VOICES; i++)
        if (pl->voices[i].program && voice_end(&pl->voices[i]) <= pl->committed)
            pl->voices[i].program = NULL;
}

void hd_player_set_timeline(struct hd_player *pl, uint64_t frame, uint32_t window)
{
    /* Frames before `frame` (the pre-fill) are silence, which is what the
     * player renders without voices: a rewind may reach into them too. */
    pl->frame = frame;
    pl->committed = frame > window ? frame - window : 0;
    pl->rewind_window = window;
}

uint64_t hd_player_rewindable(const struct hd_player *pl) { return pl->frame - pl->committed; }

uint64_t hd_player_rewind(struct hd_player *pl, uint64_t frames)
{
    uint64_t n = hd_player_rewindable(pl);
    if (frames < n)
        n = frames;
    pl->frame -= n;
    return n;
}

uint32_t hd_player_active(const struct hd_player *pl)
{
    uint32_t n = 0;
    for (unsigned v = 0; v < HD_MAX_VOICES; v++)
        n += pl->voices[v].program && voice_end(&pl->voices[v]) > pl->frame;
    return n;
}

int hd_player_uses(const struct hd_player *pl, const struct hd_program *p)
{
    for (unsigned v = 0; v < HD_MAX_VOICES; v++)
        if (pl->voices[v].program == p)
            return 1;
    return 0;
}
