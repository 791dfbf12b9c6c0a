/* Board text to hd_board_parse_string(): must never crash or overread, and
 * a board it accepts must be one hapticd can use as is. The board's path is
 * under /nonexistent: relative paths in the text resolve there, and the
 * parser opens nothing (neither does this harness: it writes no file).
 * Invariants: 0, -EINVAL or -ENOMEM; on 0 every field in the range board.c
 * validates (and docs/firmware.md documents); on an error a non-empty
 * one-line message "PATH:..." NUL-terminated in HD_ERR_MAX. Parsing is
 * deterministic: the same text gives the same board byte for byte.
 * Control bytes (ESC...) in a message are not checked here (the log escapes
 * them). An accepted text keeps board.h's text rule: lines of at most
 * HD_BOARD_LINE_MAX bytes, no control byte but tab and CR (UTF-8 validity is
 * left to the unit tests). */
#include "board.h"
#include "touch.h"
#include "trigger.h"

#include <haptic_stretch.h>

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static const char board_path[] = "/nonexistent/hapticd-fuzz/board.ini";

#define CHECK(cond)                                                                                                    \
    do {                                                                                                               \
        if (!(cond))                                                                                                   \
            abort();                                                                                                   \
    } while (0)
/* A char array holds a C string (NUL inside it). */
#define TERMINATED(a) CHECK(memchr((a), '\0', sizeof(a)) != NULL)

static void check_path_field(const char *p, size_t cap)
{
    CHECK(memchr(p, '\0', cap) != NULL);
    CHECK(p[0] == '\0' || p[0] == '/'); /* relative ones were resolved against /nonexistent/... */
}

static void check_board(const struct hd_board *b)
{
    TERMINATED(b->path);
    CHECK(!strcmp(b->path, board_path));
    /* [alsa] */
    TERMINATED(b->alsa_device);
    CHECK(b->alsa_device[0] != '\0'); /* required */
    check_path_field(b->alsa_config, sizeof b->alsa_config);
    CHECK(b->channels >= 1 && b->channels <= HD_MAX_CHANNELS);
    CHECK(b->format == HD_FMT_S16_LE || b->format == HD_FMT_S32_LE);
    CHECK(b->rate_hz >= 8000 && b->rate_hz <= 768000);
    CHECK(b->period_frames >= 16 && b->period_frames <= 8192);
    CHECK(b->periods >= 2 && b->periods <= 32);
    CHECK(b->map_count >= 1 && b->map_count <= b->channels);
    for (unsigned i = 0; i < b->map_count; i++) {
        CHECK(b->channel_map[i] < b->channels);
        for (unsigned j = 0; j < i; j++)
            CHECK(b->channel_map[j] != b->channel_map[i]);
    }
    CHECK(b->pacing == HD_PACE_DEVICE || b->pacing == HD_PACE_CLOCK);
    CHECK(b->rewind_margin_frames <= 8192);
    CHECK(strcmp(hd_format_name(b->format), "?") != 0);
    /* [gpio], [line N] */
    TERMINATED(b->gpio_chip);
    CHECK(b->lockout_ms <= 10000);
    CHECK(b->line_count <= HD_MAX_LINES);
    CHECK(b->line_count == 0 || b->gpio_chip[0] != '\0');
    for (unsigned i = 0; i < b->line_count; i++) {
        const struct hd_line *l = &b->lines[i];
        CHECK(l->offset <= 1023);
        CHECK(l->focus_count >= 1 && l->focus_count <= HD_MAX_EVENT_FOCI);
        CHECK(l->bias == HD_BIAS_AS_IS || l->bias == HD_BIAS_DISABLE || l->bias == HD_BIAS_PULL_UP ||
              l->bias == HD_BIAS_PULL_DOWN);
        for (unsigned j = 0; j < i; j++)
            CHECK(b->lines[j].offset != l->offset);
    }
    /* The trigger state the daemon builds from it finds every line. */
    struct hd_trigger t;
    hd_trigger_init(&t, b);
    CHECK(t.line_count == b->line_count);
    for (unsigned i = 0; i < b->line_count; i++)
        CHECK(hd_trigger_line_index(&t, b->lines[i].offset) == (int)i);
    /* [touch] */
    const struct hd_touch_board *tb = &b->touch;
    TERMINATED(tb->device);
    TERMINATED(tb->name);
    if (tb->enabled) {
        CHECK(!tb->device[0] != !tb->name[0]); /* exactly one */
        CHECK(tb->device[0] == '\0' || tb->device[0] == '/');
        CHECK(tb->calib_set == 0 || tb->calib_set == 7);
        CHECK(tb->calib_set || tb->has_area);
        if (tb->has_area) {
            for (int k = 0; k < 4; k++)
                CHECK(isfinite(tb->area_m[k]));
            CHECK(tb->area_m[0] != tb->area_m[2] && tb->area_m[1] != tb->area_m[3]);
        }
        if (tb->calib_set) {
            double panel[6], plate[6];
            for (int k = 0; k < 3; k++) {
                for (int j = 0; j < 4; j++)
                    CHECK(isfinite(tb->calib[k][j]));
                panel[2 * k] = tb->calib[k][0];
                panel[2 * k + 1] = tb->calib[k][1];
                plate[2 * k] = tb->calib[k][2];
                plate[2 * k + 1] = tb->calib[k][3];
            }
            struct hd_touch_map m;
            CHECK(hd_touch_map_from_points(panel, plate, &m) == 0); /* the daemon builds the same map */
        }
        CHECK(tb->max_distance_m > 0 && tb->max_distance_m <= 10);
        CHECK(tb->hysteresis_m >= 0 && tb->hysteresis_m <= 1);
    } else {
        CHECK(!tb->has_area && !tb->calib_set && !tb->device[0] && !tb->name[0]);
    }
    /* [mixer] */
    CHECK(b->gain_limit > 0 && b->gain_limit <= 16);
    /* [panel] */
    CHECK(b->panel.speed_ratio >= HAPTIC_STRETCH_MIN_RATIO && b->panel.speed_ratio <= HAPTIC_STRETCH_MAX_RATIO);
    check_path_field(b->panel.temperature_input, sizeof b->panel.temperature_input);
    CHECK(b->panel.temperature_poll_s >= 0.2 && b->panel.temperature_poll_s <= 3600);
    CHECK(b->panel.temperature_step_k > 0 && b->panel.temperature_step_k <= 50);
    /* [table] */
    check_path_field(b->table_path, sizeof b->table_path);
    /* [realtime] */
    CHECK(b->rt_priority >= 0 && b->rt_priority <= 99);
}

/* The text rule board.h states, on a text the parser accepted. */
static void check_text(const char *text)
{
    size_t column = 0;
    for (const unsigned char *p = (const unsigned char *)text; *p; p++) {
        if (*p == '\n') {
            column = 0;
            continue;
        }
        CHECK(++column <= HD_BOARD_LINE_MAX);
        CHECK((*p >= 0x20 || *p == '\t' || *p == '\r') && *p != 0x7F);
    }
}

static void check_error(const char *err)
{
    CHECK(memchr(err, '\0', HD_ERR_MAX) != NULL);
    CHECK(err[0] != '\0');
    CHECK(!strchr(err, '\n')); /* one line */
    size_t n = strlen(board_path);
    CHECK(!strncmp(err, board_path, n) && err[n] == ':'); /* "FILE:LINE: ..." or "FILE: ..." */
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* Exact-size NUL-terminated copy: ASan sees a read past the text's end. */
    char *text = malloc(size + 1);
    memcpy(text, data, size);
    text[size] = '\0';
    struct hd_board *b = malloc(sizeof *b), *again = malloc(sizeof *again);
    char *err = malloc(HD_ERR_MAX), *err_again = malloc(HD_ERR_MAX);
    memset(b, 0xA5, sizeof *b); /* hd_board_defaults must clear whatever was there */
    memset(again, 0x5A, sizeof *again);
    memset(err, 0xA5, HD_ERR_MAX); /* a missing NUL shows */
    memset(err_again, 0xA5, HD_ERR_MAX);

    int rc = hd_board_parse_string(text, board_path, b, err);
    if (rc == 0) {
        check_board(b);
        check_text(text);
    } else if (rc == -EINVAL || rc == -ENOMEM)
        check_error(err);
    else
        abort();

    /* Deterministic, and nothing of the previous board leaks into the next. */
    int rc_again = hd_board_parse_string(text, board_path, again, err_again);
    CHECK(rc_again == rc);
    if (rc == 0)
        CHECK(!memcmp(b, again, sizeof *b));
    else
        CHECK(!strcmp(err, err_again));

    free(err_again);
    free(err);
    free(again);
    free(b);
    free(text);
    return 0;
}
