/* fw_render.c - fw_render.h: hapticd's program, player and mixer, as the
 * daemon runs them. */
#include "fw_render.h"

#include "player.h"
#include "program.h"

#include <stdio.h>
#include <string.h>

int fw_render_s16(const char *table_path, const uint32_t *ids, unsigned count, int16_t *out, uint32_t frames)
{
    haptic_table t;
    haptic_table_error terr;
    if (haptic_table_open(table_path, &t, &terr)) {
        fprintf(stderr, "%s: %s\n", table_path, terr.message);
        return -1;
    }
    struct hd_board b;
    hd_board_defaults(&b);
    strcpy(b.path, "fw_render");
    strcpy(b.alsa_device, "fw_render");
    b.channels = b.map_count = t.channel_count;
    for (unsigned c = 0; c < b.channels; c++)
        b.channel_map[c] = c;
    b.format = HD_FMT_S16_LE;
    b.rate_hz = t.sample_rate_hz;
    b.max_foci = count;
    haptic_table_close(&t);
    char err[HD_ERR_MAX];
    struct hd_program *p;
    if (hd_program_load(table_path, &b, &p, err)) {
        fprintf(stderr, "%s\n", err);
        return -1;
    }
    struct hd_player pl;
    int rc = hd_player_init(&pl, &b);
    if (rc == 0 && hd_player_start(&pl, p, ids, count) != 1)
        rc = -1;
    for (uint32_t at = 0; rc == 0 && at < frames; at += b.period_frames) {
        const uint32_t n = frames - at < b.period_frames ? frames - at : b.period_frames;
        hd_player_render(&pl, out + (size_t)at * b.channels, n);
    }
    hd_player_free(&pl);
    hd_program_free(p);
    return rc;
}
