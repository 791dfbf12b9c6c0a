/* program.c - table loading and the precomputation for the mixer. */
#define _POSIX_C_SOURCE 200809L
#include "program.h"

#include <haptic_stretch.h>

#include <math.h>

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int cmp_key(const void *a, const void *b)
{
    const struct hd_focus_key *x = a, *y = b;
    return x->id < y->id ? -1 : x->id > y->id;
}

int32_t hd_program_find(const struct hd_program *p, uint32_t id)
{
    uint32_t lo = 0, hi = p->focus_count;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (p->by_id[mid].id < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < p->focus_count && p->by_id[lo].id == id ? (int32_t)p->by_id[lo].index : -1;
}

static int check_against_board(const haptic_table *t, const char *path, const struct hd_board *b, char err[HD_ERR_MAX])
{
    if (t->sample_rate_hz != b->rate_hz) {
        snprintf(err, HD_ERR_MAX, "%s: table rate %lu Hz does not match the board's [alsa] rate_hz %u (%s)", path,
                 (unsigned long)t->sample_rate_hz, b->rate_hz, b->path);
        return -EINVAL;
    }
    if (t->channel_count != b->map_count) {
        snprintf(err, HD_ERR_MAX,
                 "%s: table has %u exciter channels, the board's [alsa] channel_map has %u entries (%s)", path,
                 (unsigned)t->channel_count, b->map_count, b->path);
        return -EINVAL;
    }
    return 0;
}

/* The peak envelope of the drives as played (hd_program_signal). */
static int compute_block_peaks(struct hd_program *p)
{
    p->blocks = haptic_mix_blocks(p->samples);
    free(p->block_peak);
    p->block_peak = calloc((size_t)p->focus_count * p->blocks * p->channel_count, sizeof *p->block_peak);
    if (!p->block_peak)
        return -ENOMEM;
    for (uint32_t f = 0; f < p->focus_count; f++)
        haptic_mix_block_peaks(hd_program_signal(p, f), p->samples, p->channel_count,
                               p->block_peak + (size_t)f * p->blocks * p->channel_count);
    /* Each drive's energy per channel, for the exciters' ratings. */
    free(p->root_energy);
    p->root_energy = calloc((size_t)p->focus_count * p->channel_count, sizeof *p->root_energy);
    if (!p->root_energy)
        return -ENOMEM;
    for (uint32_t f = 0; f < p->focus_count; f++) {
        const int16_t *s = hd_program_signal(p, f);
        double *e = p->root_energy + (size_t)f * p->channel_count;
        for (uint32_t n = 0; n < p->samples; n++)
            for (uint32_t c = 0; c < p->channel_count; c++) {
                const double v = s[(size_t)n * p->channel_count + c];
                e[c] += v * v;
            }
        for (uint32_t c = 0; c < p->channel_count; c++)
            e[c] = sqrt(e[c]);
    }
    return 0;
}

int hd_program_from_table(const haptic_table *t, const struct hd_board *b, struct hd_program **out,
                          char err[HD_ERR_MAX])
{
    int rc = check_against_board(t, "table", b, err);
    if (rc)
        return rc;
    struct hd_program *p = calloc(1, sizeof *p);
    if (!p)
        goto nomem;
    p->table = *t;
    p->table.owned = NULL;
    p->focus_count = t->focus_count;
    p->channel_count = t->channel_count;
    p->samples = t->samples_per_signal;
    p->speed_ratio = 1.0;
    p->by_id = calloc(p->focus_count, sizeof *p->by_id);
    if (!p->by_id || compute_block_peaks(p) != 0)
        goto nomem;
    if (t->range_offset) { /* copied once: the real-time path reads an array, not the file's bytes */
        p->range = calloc(p->focus_count, sizeof *p->range);
        if (!p->range)
            goto nomem;
        for (uint32_t f = 0; f < p->focus_count; f++)
            haptic_table_gain_range(t, f, &p->range[f]);
    }
    for (uint32_t f = 0; f < p->focus_count; f++) {
        haptic_focus_info info;
        haptic_table_focus(t, f, &info);
        p->by_id[f].id = info.id;
        p->by_id[f].index = f;
    }
    qsort(p->by_id, p->focus_count, sizeof *p->by_id, cmp_key);
    *out = p;
    return 0;
nomem:
    hd_program_free(p);
    snprintf(err, HD_ERR_MAX, "out of memory preparing the table");
    return -ENOMEM;
}

int hd_program_load(const char *path, const struct hd_board *b, struct hd_program **out, char err[HD_ERR_MAX])
{
    haptic_table t;
    haptic_table_error terr;
    if (haptic_table_open(path, &t, &terr) != 0) {
        snprintf(err, HD_ERR_MAX, "%s: %s", path, terr.message);
        return terr.code == HAPTIC_TABLE_ENOMEM ? -ENOMEM : -EINVAL;
    }
    int rc = check_against_board(&t, path, b, err);
    if (rc == 0)
        rc = hd_program_from_table(&t, b, out, err);
    if (rc) {
        haptic_table_close(&t);
        return rc;
    }
    (*out)->table.owned = t.owned; /* the program now frees the file buffer */
    snprintf((*out)->path, sizeof(*out)->path, "%s", path);
    return 0;
}

/* Drops a stretch: the program plays the table as stored again. */
static void unstretch(struct hd_program *p)
{
    free(p->stretched);
    free(p->gram);
    p->stretched = NULL;
    p->gram = NULL;
    p->samples = p->table.samples_per_signal;
    p->speed_ratio = 1.0;
    p->stretch_clipped = 0;
}

int hd_program_set_speed(struct hd_program *p, double speed_ratio, char err[HD_ERR_MAX])
{
    if (speed_ratio == p->speed_ratio)
        return 0;
    const uint32_t N = p->table.samples_per_signal, C = p->channel_count, K = p->focus_count;
    const uint32_t M = haptic_stretch_frames(N, speed_ratio);
    if (p->stretched) {
        snprintf(err, HD_ERR_MAX, "speed ratio %.6g: the program is stretched already", speed_ratio);
        return -EINVAL;
    }
    if (M == 0) {
        snprintf(err, HD_ERR_MAX, "speed ratio %.6g: outside %g..%g", speed_ratio, HAPTIC_STRETCH_MIN_RATIO,
                 HAPTIC_STRETCH_MAX_RATIO);
        return -EINVAL;
    }
    const uint64_t products = (uint64_t)K * (K + 1) / 2 * M * C;
    if (products > HD_STRETCH_MAX_PRODUCTS) {
        snprintf(err, HD_ERR_MAX,
                 "%u foci x %u frames x %u channels: the stretched drives' Gram matrix takes %.3g products, more "
                 "than the %.3g a stretch may take on the main thread",
                 (unsigned)K, (unsigned)M, (unsigned)C, (double)products, (double)HD_STRETCH_MAX_PRODUCTS);
        return -E2BIG;
    }
    int rc = -ENOMEM;
    p->stretched = malloc((size_t)M * C * K * sizeof *p->stretched);
    p->gram = malloc((size_t)K * K * sizeof *p->gram);
    if (!p->stretched || !p->gram)
        goto fail;
    for (uint32_t f = 0; f < K; f++) {
        rc = haptic_stretch(haptic_table_signal(&p->table, f), N, C, speed_ratio, p->stretched + (size_t)f * M * C,
                            &p->stretch_clipped);
        if (rc)
            goto fail;
    }
    /* Exact, as the table's own: the mixer's energy normalisation holds for what plays. */
    haptic_table_gram_of(p->stretched, K, (uint64_t)M * C, p->gram);
    p->samples = M;
    p->speed_ratio = speed_ratio;
    if ((rc = compute_block_peaks(p)) == 0)
        return 0;
fail:
    unstretch(p);
    if (compute_block_peaks(p) != 0)
        rc = -ENOMEM;
    if (rc == -ENOMEM)
        snprintf(err, HD_ERR_MAX, "out of memory stretching the table by %.6g", speed_ratio);
    else
        snprintf(err, HD_ERR_MAX, "speed ratio %.6g: the resampler failed", speed_ratio);
    return rc;
}

int hd_program_clone(const struct hd_program *src, const struct hd_board *b, struct hd_program **out,
                     char err[HD_ERR_MAX])
{
    void *copy = malloc(src->table.size);
    if (!copy) {
        snprintf(err, HD_ERR_MAX, "out of memory copying the table");
        return -ENOMEM;
    }
    memcpy(copy, src->table.data, src->table.size);
    haptic_table t = src->table; /* the offsets hold for the copy: the bytes are the same */
    t.data = copy;
    t.owned = NULL;
    int rc = hd_program_from_table(&t, b, out, err);
    if (rc) {
        free(copy);
        return rc;
    }
    (*out)->table.owned = copy;
    snprintf((*out)->path, sizeof(*out)->path, "%s", src->path);
    return 0;
}

void hd_program_free(struct hd_program *p)
{
    if (!p)
        return;
    haptic_table_close(&p->table);
    free(p->by_id);
    free(p->block_peak);
    free(p->root_energy);
    free(p->range);
    free(p->stretched);
    free(p->gram);
    free(p);
}

double hd_program_lead_time_s(const struct hd_program *p)
{
    /* A touch may select any focus, so the latency to state is the slowest
     * focus's: the largest lead time. A 1.0 table has none (NaN for every
     * focus), and it cannot be derived from the samples alone: the peak forms
     * at the focus, not at an exciter. */
    double lead = NAN;
    for (uint32_t i = 0; i < p->table.focus_count; i++) {
        double s = haptic_table_lead_time_s(&p->table, i);
        if (isfinite(s) && (isnan(lead) || s > lead))
            lead = s;
    }
    return lead / p->speed_ratio;
}

int hd_program_voice_range(const struct hd_program *p, const uint32_t *index, uint32_t count, haptic_gain_range *out)
{
    if (!p->range || count == 0)
        return 0;
    *out = p->range[index[0]];
    for (uint32_t k = 1; k < count; k++)
        haptic_gain_range_intersect(out, &p->range[index[k]]);
    return 1;
}

/* The foci the clamp moves one way: how many, and the dB span of where they play. */
struct moved {
    uint32_t count;
    double min_db, max_db;
};

static void moved_add(struct moved *m, double gain)
{
    const double db = 20 * log10(gain);
    if (m->count == 0 || db < m->min_db)
        m->min_db = db;
    if (m->count == 0 || db > m->max_db)
        m->max_db = db;
    m->count++;
}

int hd_program_range_note(const struct hd_program *p, double level, char *out, size_t cap)
{
    if (cap)
        out[0] = '\0';
    if (!p->range || cap == 0)
        return 0;
    struct moved above = {0}, below = {0}, failing = {0};
    for (uint32_t f = 0; f < p->focus_count; f++) {
        const haptic_gain_range *r = &p->range[f];
        const double g = haptic_gain_range_clamp(r, level);
        if (!(r->lo < r->hi))
            moved_add(&failing, g);
        else if (g < level)
            moved_add(&above, g);
        else if (g > level)
            moved_add(&below, g);
    }
    const unsigned k = p->focus_count;
    char a[160] = "", b[160] = "", c[160] = "";
    if (above.count)
        snprintf(a, sizeof a, " above the safe range of %u of %u foci (tops %+.1f..%+.1f dB): they play at their tops",
                 (unsigned)above.count, k, above.min_db, above.max_db);
    if (below.count)
        snprintf(b, sizeof b,
                 "%s below the safe range of %u of %u foci (bottoms %+.1f..%+.1f dB): they play at their "
                 "bottoms",
                 a[0] ? ";" : "", (unsigned)below.count, k, below.min_db, below.max_db);
    if (failing.count)
        snprintf(c, sizeof c, "%s %u of %u foci pass at no gain (tops %+.1f..%+.1f dB): they play at their tops",
                 a[0] || b[0] ? ";" : "", (unsigned)failing.count, k, failing.min_db, failing.max_db);
    const uint32_t moved = above.count + below.count + failing.count;
    if (moved)
        snprintf(out, cap, "intensity %+.1f dB:%s%s%s", 20 * log10(level), a, b, c);
    return (int)moved;
}
