/* A deterministic 8-channel table for the benchmarks (uniform noise, the
 * statistics of a time-reversed reverberant recording are close enough for
 * timing: the mixer's cost does not depend on the values). */
#ifndef BENCH_TABLE_H
#define BENCH_TABLE_H
#include <haptic_table.h>
#include <stdlib.h>

static int bench_table_write(const char *path, uint32_t foci, uint32_t samples)
{
    const uint16_t C = 8;
    int16_t *s = malloc((size_t)foci * samples * C * sizeof *s);
    double cxy[16], *fxy = calloc(2 * foci, sizeof *fxy), *scale = calloc(foci, sizeof *scale);
    uint32_t *ids = calloc(foci, sizeof *ids), x = 1;
    if (!s || !fxy || !scale || !ids)
        return -1;
    for (size_t i = 0; i < (size_t)foci * samples * C; i++) {
        x = x * 1664525u + 1013904223u;
        s[i] = (int16_t)((int)(x >> 16) % 12000 - 6000);
    }
    for (int c = 0; c < 16; c++)
        cxy[c] = 0.05 * c;
    for (uint32_t f = 0; f < foci; f++) {
        ids[f] = f;
        fxy[2 * f] = fxy[2 * f + 1] = 0.1 + 0.05 * f;
        scale[f] = 1e-5;
    }
    haptic_table_spec spec = {.sample_rate_hz = 48000,
                              .channel_count = C,
                              .focus_count = foci,
                              .samples_per_signal = samples,
                              .channel_xy_m = cxy,
                              .focus_id = ids,
                              .focus_xy_m = fxy,
                              .focus_scale_m = scale,
                              .samples = s,
                              .scene_name = "bench"};
    haptic_table_error err;
    int rc = haptic_table_write(path, &spec, &err);
    free(s), free(fxy), free(scale), free(ids);
    return rc;
}
#endif
