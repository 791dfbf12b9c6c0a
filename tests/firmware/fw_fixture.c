#include "fw_fixture.h"

#include <assert.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void fw_table_make(struct fw_table *t, uint16_t channels, uint32_t foci, uint32_t samples, enum fw_kind kind, int amp,
                   uint32_t seed)
{
    memset(t, 0, sizeof *t);
    t->channels = channels;
    t->foci = foci;
    t->samples = samples;
    t->channel_xy = calloc(2u * channels, sizeof(double));
    t->focus_xy = calloc(2u * foci, sizeof(double));
    t->scale = calloc(foci, sizeof(double));
    t->ids = calloc(foci, sizeof(uint32_t));
    t->samples_buf = calloc((size_t)foci * samples * channels, sizeof(int16_t));
    assert(t->channel_xy && t->focus_xy && t->scale && t->ids && t->samples_buf);
    for (unsigned c = 0; c < channels; c++) {
        t->channel_xy[2 * c] = 0.01 * c;
        t->channel_xy[2 * c + 1] = 0.02;
    }
    uint32_t x = seed * 2654435761u + 12345u;
    for (uint32_t f = 0; f < foci; f++) {
        t->ids[f] = 1000 - 10 * f;
        t->focus_xy[2 * f] = 0.1 + 0.01 * f;
        t->focus_xy[2 * f + 1] = 0.2;
        t->scale[f] = 1e-5;
        uint32_t slot = samples / foci;
        for (uint32_t n = 0; n < samples; n++)
            for (uint32_t c = 0; c < channels; c++) {
                int v;
                x = x * 1664525u + 1013904223u;
                switch (kind) {
                case FW_RANDOM:
                    v = (int)((x >> 8) % (uint32_t)(2 * amp + 1)) - amp;
                    break;
                case FW_DISJOINT:
                    v = n / slot == f ? ((x >> 31) ? amp : -amp) : 0;
                    break;
                default:
                    v = amp;
                    break;
                }
                t->samples_buf[((size_t)f * samples + n) * channels + c] = (int16_t)v;
            }
    }
    fw_table_encode(t, NULL);
}

void fw_table_encode(struct fw_table *t, const double *lead_time_s)
{
    haptic_table_spec spec = {
        .sample_rate_hz = 48000,
        .channel_count = t->channels,
        .focus_count = t->foci,
        .samples_per_signal = t->samples,
        .channel_xy_m = t->channel_xy,
        .focus_id = t->ids,
        .focus_xy_m = t->focus_xy,
        .focus_scale_m = t->scale,
        .samples = t->samples_buf,
        .scene_name = "fw-test",
        .drive_kind = lead_time_s ? HAPTIC_DRIVE_FORCE : HAPTIC_DRIVE_UNKNOWN,
        .force_full_scale_n = lead_time_s ? 0.5 : 0.0,
        .focus_lead_time_s = lead_time_s,
        .panel = t->panel,
        .range = t->range,
    };
    free(t->buf);
    t->size = (size_t)haptic_table_encoded_size(&spec);
    assert(t->size > 0);
    t->buf = malloc(t->size);
    haptic_table_error err;
    int rc = haptic_table_encode(&spec, t->buf, t->size, &err);
    assert(rc == 0);
    rc = haptic_table_validate(t->buf, t->size, &t->table, &err);
    assert(rc == 0);
    (void)rc;
}

void fw_table_free(struct fw_table *t)
{
    free(t->channel_xy);
    free(t->focus_xy);
    free(t->scale);
    free(t->ids);
    free(t->samples_buf);
    free(t->buf);
    memset(t, 0, sizeof *t);
}

void fw_table_write(const struct fw_table *t, const char *path)
{
    FILE *f = fopen(path, "wb");
    assert(f);
    size_t n = fwrite(t->buf, 1, t->size, f);
    assert(n == t->size);
    fclose(f);
    (void)n;
}

void fw_write_text(const char *path, const char *text)
{
    char tmp[600];
    if (snprintf(tmp, sizeof tmp, "%s.new", path) >= (int)sizeof tmp)
        abort();
    FILE *f = fopen(tmp, "w");
    if (!f || fputs(text, f) < 0 || fclose(f) != 0 || rename(tmp, path) != 0) {
        perror(path);
        abort();
    }
}

void fw_board(struct hd_board *b, unsigned channels, enum hd_sample_format fmt, unsigned period)
{
    hd_board_defaults(b);
    strcpy(b->path, "test/board.ini");
    strcpy(b->alsa_device, "test");
    b->channels = channels;
    b->map_count = channels;
    b->format = fmt;
    b->period_frames = period;
}
