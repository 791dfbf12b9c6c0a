#include "table_fixture.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

void table_fixture_init(table_fixture *fx, uint16_t channels, uint32_t foci, uint32_t samples, uint32_t seed)
{
    memset(fx, 0, sizeof *fx);
    size_t n = (size_t)foci * samples * channels;
    fx->samples = malloc(n * sizeof *fx->samples);
    uint32_t s = seed;
    for (size_t i = 0; i < n; i++) {
        s = s * 1664525u + 1013904223u;
        fx->samples[i] = (int16_t)(s >> 16);
    }
    fx->samples[0] = INT16_MIN;
    fx->samples[n - 1] = INT16_MAX;
    for (uint16_t c = 0; c < channels; c++) {
        fx->channel_xy[2 * c] = 0.01 * c;
        fx->channel_xy[2 * c + 1] = 0.7 - 0.02 * c;
    }
    for (uint32_t f = 0; f < foci; f++) {
        fx->ids[f] = 10 * (f + 1);
        fx->focus_xy[2 * f] = 0.1 + 0.05 * f;
        fx->focus_xy[2 * f + 1] = 0.2 + 0.01 * f;
        fx->scale[f] = 1e-5 * (f + 1);
        fx->lead_s[f] = (f % 4 + 1) * 0.25 * samples / 48000.0;
        fx->gain_range[f].lo = 0.5 / (f + 1);
        fx->gain_range[f].hi = f + 1 == foci ? INFINITY : 2.0 * (f + 1);
    }
    fx->range.threshold_m = 1e-6;
    fx->range.scope = HAPTIC_RANGE_WHOLE_AREA;
    fx->range.focus = fx->gain_range;
    haptic_table_spec *sp = &fx->spec;
    sp->sample_rate_hz = 48000;
    sp->channel_count = channels;
    sp->focus_count = foci;
    sp->samples_per_signal = samples;
    sp->channel_xy_m = fx->channel_xy;
    sp->focus_id = fx->ids;
    sp->focus_xy_m = fx->focus_xy;
    sp->focus_scale_m = fx->scale;
    sp->samples = fx->samples;
    sp->scene_name = "fixture";
    sp->scene_hash = "fnv1a64:0123456789abcdef";
    sp->tool_version = "test 0";
    sp->created_utc = "2026-11-21T00:00:00Z";
    sp->drive_kind = HAPTIC_DRIVE_EXCITER;
    sp->force_full_scale_n = 2.5;
    sp->focus_lead_time_s = fx->lead_s;
    fx->panel.temperature_c = 23.0;
    fx->panel.youngs_per_k = -0.004;
    sp->panel = &fx->panel;
}

void table_fixture_free(table_fixture *fx)
{
    free(fx->samples);
    fx->samples = NULL;
}

size_t table_fixture_encode(const table_fixture *fx, uint8_t **out)
{
    uint64_t size = haptic_table_encoded_size(&fx->spec);
    *out = NULL;
    if (!size)
        return 0;
    uint8_t *b = malloc((size_t)size);
    if (haptic_table_encode(&fx->spec, b, (size_t)size, NULL) != 0) {
        free(b);
        return 0;
    }
    *out = b;
    return (size_t)size;
}

void table_fixture_fix_crc(uint8_t *buf, size_t size)
{
    uint32_t crc = (uint32_t)crc32(crc32(0L, Z_NULL, 0), buf, (uInt)(size - 4));
    for (int i = 0; i < 4; i++)
        buf[size - 4 + i] = (uint8_t)(crc >> (8 * i));
}
