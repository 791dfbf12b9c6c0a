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
    pl->acc = calloc((size_t)pl->frames_max * pl->channels, sizeof *pl->acc);
    return pl->acc ? 0 : -ENOMEM;
}

void hd_player_free(struct hd_player *pl)
{
    free(pl->acc);
    pl->acc = NULL;
}

static struct hd_voice *free_slot(struct hd_player *pl)
{
    struct hd_voice *oldest = &pl->voices[0];
    for (unsigned v = 0; v < HD_MAX_VOICES; v++) {
        if (!pl->voices[v].program)
            return &pl->voices[v];
        if (pl->voices[v].position > oldest->position)
            oldest = &pl->voices[v];
    }
    pl->stats.voices_stolen++;
    return oldest;
}

void hd_player_start_mix(struct hd_player *pl, const struct hd_program *p, const struct hd_mix *m)
{
    struct hd_voice *v = free_slot(pl);
    v->program = p;
    v->mix = *m;
    v->position = 0;
    pl->stats.voices_started++;
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
    if (m.count == 0 || hd_mixer_gain(p, pl->gain_limit, &m) != 0)
        return 0;
    hd_player_start_mix(pl, p, &m);
    return 1;
}

static void render_voice(struct hd_player *pl, struct hd_voice *v, uint32_t frames)
{
    const struct hd_program *p = v->program;
    const uint32_t C = p->channel_count, K = v->mix.count, chs = pl->channels;
    uint32_t n = p->samples - v->position;
    if (n > frames)
        n = frames;
    const int16_t *sig[HD_MAX_VOICE_FOCI];
    for (uint32_t k = 0; k < K; k++)
        sig[k] = hd_program_signal(p, v->mix.index[k]) + (size_t)v->position * C;
    const int64_t g = v->mix.gain_q30;
    for (uint32_t i = 0; i < n; i++) {
        int64_t *row = pl->acc + (size_t)i * chs;
        for (uint32_t c = 0; c < C; c++) {
            int32_t s = 0; /* exact: |sum| <= 32 * 32768 */
            for (uint32_t k = 0; k < K; k++)
                s += sig[k][(size_t)i * C + c];
            row[pl->channel_map[c]] += (int64_t)s * g;
        }
    }
    v->position += n;
    if (v->position >= p->samples)
        v->program = NULL;
}

void hd_player_render(struct hd_player *pl, void *out, uint32_t frames)
{
    const uint32_t n = frames * pl->channels;
    memset(pl->acc, 0, (size_t)n * sizeof *pl->acc);
    for (unsigned v = 0; v < HD_MAX_VOICES; v++)
        if (pl->voices[v].program)
            render_voice(pl, &pl->voices[v], frames);
    pl->stats.clipped_samples += pl->format == HD_FMT_S16_LE ? hd_mixer_to_s16(pl->acc, out, n)
                                                             : hd_mixer_to_s32(pl->acc, out, n);
}

uint32_t hd_player_active(const struct hd_player *pl)
{
    uint32_t n = 0;
    for (unsigned v = 0; v < HD_MAX_VOICES; v++)
        n += pl->voices[v].program != NULL;
    return n;
}

int hd_player_uses(const struct hd_player *pl, const struct hd_program *p)
{
    for (unsigned v = 0; v < HD_MAX_VOICES; v++)
        if (pl->voices[v].program == p)
            return 1;
    return 0;
}
