/* board.c - board.ini parser (inih). Unknown sections and keys are errors:
 * a typo in a board file must not silently fall back to a default. */
#define _POSIX_C_SOURCE 200809L
#include "board.h"

#include "protect.h"
#include "text.h"
#include "touch.h"

#include <haptic_file.h>
#include <haptic_stretch.h>
#include <ini.h>

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

struct parse_ctx {
    struct hd_board *b;
    char dir[HD_PATH_MAX]; /* folder of the board file, for relative paths */
    char msg[HD_ERR_MAX];  /* first error: "[section] key: ..." */
    bool failed;
    uint32_t seen_lines; /* which b->lines[] came from a section */
};

void hd_board_defaults(struct hd_board *b)
{
    memset(b, 0, sizeof *b);
    b->channels = 8;
    b->format = HD_FMT_S32_LE;
    b->rate_hz = 48000;
    b->period_frames = 64;
    b->periods = 2;
    b->map_count = 8;
    for (unsigned c = 0; c < HD_MAX_CHANNELS; c++)
        b->channel_map[c] = c;
    b->pacing = HD_PACE_DEVICE;
    b->rewind = true;
    b->rewind_margin_frames = 32;
    b->lockout_ms = 50;
    b->gain_limit = 1.0;
    b->max_foci = HD_DEFAULT_MAX_FOCI;
    b->foci_policy = HD_FOCI_NEWEST;
    b->panel.speed_ratio = 1.0;
    b->panel.temperature_poll_s = 10.0;
    b->panel.temperature_step_k = 0.5;
    b->touch.max_distance_m = 0.05;
    b->touch.hysteresis_m = 0.005;
    b->rt_priority = 80;
    b->mlock = true;
    b->capture.channels = 8;
    b->capture.format = HD_FMT_S32_LE;
}

const char *hd_format_name(enum hd_sample_format f)
{
    return f == HD_FMT_S16_LE ? "S16_LE" : f == HD_FMT_S32_LE ? "S32_LE" : "?";
}

__attribute__((format(printf, 4, 5))) static int bad(struct parse_ctx *c, const char *section, const char *key,
                                                     const char *fmt, ...)
{
    if (!c->failed) {
        int n = snprintf(c->msg, sizeof c->msg, "[%s] %s: ", section, key);
        if (n < 0 || (size_t)n >= sizeof c->msg)
            n = 0;
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(c->msg + n, sizeof c->msg - (size_t)n, fmt, ap);
        va_end(ap);
        c->failed = true;
    }
    return 0; /* inih: handler error */
}

static int parse_uint(const char *s, unsigned long lo, unsigned long hi, unsigned long *out)
{
    char *end;
    if (!*s || *s == '-' || *s == '+')
        return -EINVAL;
    errno = 0;
    unsigned long v = strtoul(s, &end, 10);
    if (errno || *end || v < lo || v > hi)
        return -EINVAL;
    *out = v;
    return 0;
}

static int parse_bool(const char *s, bool *out)
{
    if (!strcasecmp(s, "true") || !strcasecmp(s, "yes") || !strcmp(s, "1") || !strcasecmp(s, "on"))
        *out = true;
    else if (!strcasecmp(s, "false") || !strcasecmp(s, "no") || !strcmp(s, "0") || !strcasecmp(s, "off"))
        *out = false;
    else
        return -EINVAL;
    return 0;
}

int hd_parse_uint_list(const char *s, uint32_t *out, unsigned max, uint32_t limit)
{
    unsigned n = 0;
    const char *p = s;
    for (;;) {
        while (*p == ' ' || *p == '\t')
            p++;
        if (*p < '0' || *p > '9')
            return -EINVAL;
        char *end;
        errno = 0;
        unsigned long v = strtoul(p, &end, 10);
        if (errno || v > limit || n >= max)
            return -EINVAL;
        out[n++] = (uint32_t)v;
        p = end;
        while (*p == ' ' || *p == '\t')
            p++;
        if (*p == '\0')
            return (int)n;
        if (*p != ',')
            return -EINVAL;
        p++;
    }
}

static int copy_str(struct parse_ctx *c, const char *sec, const char *key, char *dst, size_t cap, const char *v)
{
    if (!*v)
        return bad(c, sec, key, "empty value");
    if (strlen(v) >= cap)
        return bad(c, sec, key, "longer than %zu characters", cap - 1);
    strcpy(dst, v);
    return 1;
}

static int copy_path(struct parse_ctx *c, const char *sec, const char *key, char *dst, const char *v)
{
    if (!*v)
        return bad(c, sec, key, "empty path");
    int n = v[0] == '/' ? snprintf(dst, HD_PATH_MAX, "%s", v) : snprintf(dst, HD_PATH_MAX, "%s/%s", c->dir, v);
    if (n < 0 || n >= (int)HD_PATH_MAX)
        return bad(c, sec, key, "path longer than %u characters", HD_PATH_MAX - 1);
    return 1;
}

#define UINT_KEY(field, lo, hi)                                                                                        \
    do {                                                                                                               \
        unsigned long v_;                                                                                              \
        if (parse_uint(value, (lo), (hi), &v_))                                                                        \
            return bad(c, section, name, "'%s' is not an integer in %lu..%lu", value, (unsigned long)(lo),             \
                       (unsigned long)(hi));                                                                           \
        (field) = (unsigned)v_;                                                                                        \
        return 1;                                                                                                      \
    } while (0)

static int format_key(struct parse_ctx *c, const char *section, const char *name, const char *value,
                      enum hd_sample_format *out)
{
    if (!strcmp(value, "S16_LE"))
        *out = HD_FMT_S16_LE;
    else if (!strcmp(value, "S32_LE"))
        *out = HD_FMT_S32_LE;
    else
        return bad(c, section, name, "'%s' is not S16_LE or S32_LE", value);
    return 1;
}

static int alsa_key(struct parse_ctx *c, const char *section, const char *name, const char *value)
{
    struct hd_board *b = c->b;
    if (!strcmp(name, "device"))
        return copy_str(c, section, name, b->alsa_device, sizeof b->alsa_device, value);
    if (!strcmp(name, "config"))
        return copy_path(c, section, name, b->alsa_config, value);
    if (!strcmp(name, "channels"))
        UINT_KEY(b->channels, 1, HD_MAX_CHANNELS);
    if (!strcmp(name, "rate_hz"))
        UINT_KEY(b->rate_hz, 8000, 768000);
    if (!strcmp(name, "period_frames"))
        UINT_KEY(b->period_frames, 16, 8192);
    if (!strcmp(name, "periods"))
        UINT_KEY(b->periods, 2, 32);
    if (!strcmp(name, "format"))
        return format_key(c, section, name, value, &b->format);
    if (!strcmp(name, "channel_map")) {
        uint32_t map[HD_MAX_CHANNELS];
        int n = hd_parse_uint_list(value, map, HD_MAX_CHANNELS, HD_MAX_CHANNELS - 1);
        if (n < 1)
            return bad(c, section, name, "'%s' is not a list of 1..%u ALSA channel numbers (0..%u)", value,
                       HD_MAX_CHANNELS, HD_MAX_CHANNELS - 1);
        b->map_count = (unsigned)n;
        for (int i = 0; i < n; i++)
            b->channel_map[i] = map[i];
        return 1;
    }
    if (!strcmp(name, "pacing")) {
        if (!strcmp(value, "device"))
            b->pacing = HD_PACE_DEVICE;
        else if (!strcmp(value, "clock"))
            b->pacing = HD_PACE_CLOCK;
        else
            return bad(c, section, name, "'%s' is not 'device' or 'clock'", value);
        return 1;
    }
    if (!strcmp(name, "rewind")) {
        if (parse_bool(value, &b->rewind))
            return bad(c, section, name, "'%s' is not true or false", value);
        return 1;
    }
    if (!strcmp(name, "rewind_margin_frames"))
        UINT_KEY(b->rewind_margin_frames, 0, 8192);
    return bad(c, section, name, "unknown key");
}

static int line_key(struct parse_ctx *c, const char *section, const char *name, const char *value)
{
    unsigned long offset;
    if (parse_uint(section + 5, 0, 1023, &offset))
        return bad(c, section, name, "section name must be [line N] with N a GPIO line offset 0..1023");
    struct hd_board *b = c->b;
    unsigned i;
    for (i = 0; i < b->line_count; i++)
        if (b->lines[i].offset == offset)
            break;
    if (i == b->line_count) {
        if (b->line_count == HD_MAX_LINES)
            return bad(c, section, name, "more than %u trigger lines", HD_MAX_LINES);
        b->line_count++;
        memset(&b->lines[i], 0, sizeof b->lines[i]);
        b->lines[i].offset = (unsigned)offset;
    }
    struct hd_line *l = &b->lines[i];
    if (!strcmp(name, "foci")) {
        int n = hd_parse_uint_list(value, l->focus_ids, HD_MAX_EVENT_FOCI, UINT32_MAX);
        if (n < 1)
            return bad(c, section, name, "'%s' is not a list of 1..%u focus ids", value, HD_MAX_EVENT_FOCI);
        l->focus_count = (unsigned)n;
        return 1;
    }
    if (!strcmp(name, "active_low")) {
        if (parse_bool(value, &l->active_low))
            return bad(c, section, name, "'%s' is not true or false", value);
        return 1;
    }
    if (!strcmp(name, "bias")) {
        if (!strcmp(value, "as-is"))
            l->bias = HD_BIAS_AS_IS;
        else if (!strcmp(value, "disable"))
            l->bias = HD_BIAS_DISABLE;
        else if (!strcmp(value, "pull-up"))
            l->bias = HD_BIAS_PULL_UP;
        else if (!strcmp(value, "pull-down"))
            l->bias = HD_BIAS_PULL_DOWN;
        else
            return bad(c, section, name, "'%s' is not as-is, disable, pull-up or pull-down", value);
        return 1;
    }
    return bad(c, section, name, "unknown key");
}

/* One number in [lo, hi] (lo excluded unless lo_in). */
static int number_key(struct parse_ctx *c, const char *section, const char *name, const char *value, double lo,
                      bool lo_in, double hi, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(value, &end);
    if (errno || end == value || *end || !(lo_in ? v >= lo : v > lo) || !(v <= hi))
        return bad(c, section, name, "'%s' is not a number in %c%g, %g]", value, lo_in ? '[' : '(', lo, hi);
    *out = v;
    return 1;
}

/* "a, b, c" -> exactly n finite numbers. */
static int parse_doubles(const char *s, double *out, unsigned n)
{
    const char *p = s;
    for (unsigned i = 0; i < n; i++) {
        char *end;
        errno = 0;
        double v = strtod(p, &end);
        if (errno || end == p || !isfinite(v))
            return -EINVAL;
        out[i] = v;
        p = end;
        while (*p == ' ' || *p == '\t')
            p++;
        if (i + 1 < n) {
            if (*p != ',')
                return -EINVAL;
            p++;
        }
    }
    return *p ? -EINVAL : 0;
}

/* "3" or "3, 3, 2.5": 1..HD_MAX_CHANNELS numbers in (lo, hi]. */
static int rating_key(struct parse_ctx *c, const char *section, const char *name, const char *value, double lo,
                      double hi, double *out, unsigned *count)
{
    const char *p = value;
    unsigned n = 0;
    for (;;) {
        char *end;
        errno = 0;
        double v = strtod(p, &end);
        if (errno || end == p || !(v > lo) || !(v <= hi) || n == HD_MAX_CHANNELS)
            break;
        out[n++] = v;
        p = end;
        while (*p == ' ' || *p == '\t')
            p++;
        if (!*p) {
            *count = n;
            return 1;
        }
        if (*p++ != ',')
            break;
    }
    return bad(c, section, name, "'%s' is not one number or a list of up to %u, each in (%g, %g]", value,
               HD_MAX_CHANNELS, lo, hi);
}

static int exciters_key(struct parse_ctx *c, const char *section, const char *name, const char *value)
{
    struct hd_exciters_board *e = &c->b->exciters;
    if (!strcmp(name, "rated_power_w"))
        return rating_key(c, section, name, value, 0.0, 1000.0, e->rated_power_w, &e->power_count);
    if (!strcmp(name, "impedance_ohm"))
        return rating_key(c, section, name, value, 0.0, 1000.0, e->impedance_ohm, &e->impedance_count);
    if (!strcmp(name, "thermal_tau_s"))
        return rating_key(c, section, name, value, 0.0, 3600.0, e->tau_s, &e->tau_count);
    return bad(c, section, name, "unknown key");
}

static int capture_key(struct parse_ctx *c, const char *section, const char *name, const char *value)
{
    struct hd_capture_board *k = &c->b->capture;
    if (!strcmp(name, "device"))
        return copy_str(c, section, name, k->device, sizeof k->device, value);
    if (!strcmp(name, "playback_device"))
        return copy_str(c, section, name, k->playback_device, sizeof k->playback_device, value);
    if (!strcmp(name, "channels"))
        UINT_KEY(k->channels, 1, HD_MAX_CHANNELS);
    if (!strcmp(name, "rate_hz"))
        UINT_KEY(k->rate_hz, 8000, 768000);
    if (!strcmp(name, "format"))
        return format_key(c, section, name, value, &k->format);
    if (!strcmp(name, "offset_frames"))
        UINT_KEY(k->offset_frames, 0, 65536);
    return bad(c, section, name, "unknown key");
}

static int touch_key(struct parse_ctx *c, const char *section, const char *name, const char *value)
{
    struct hd_touch_board *t = &c->b->touch;
    if (!strcmp(name, "device")) {
        if (value[0] != '/')
            return bad(c, section, name, "'%s' is not an absolute path (e.g. /dev/input/event0)", value);
        return copy_str(c, section, name, t->device, sizeof t->device, value);
    }
    if (!strcmp(name, "name"))
        return copy_str(c, section, name, t->name, sizeof t->name, value);
    if (!strcmp(name, "area_m")) {
        if (parse_doubles(value, t->area_m, 4) || t->area_m[0] == t->area_m[2] || t->area_m[1] == t->area_m[3] ||
            !isfinite(t->area_m[2] - t->area_m[0]) || !isfinite(t->area_m[3] - t->area_m[1]))
            return bad(c, section, name, "'%s' is not x0,y0,x1,y1 in metres with x0 != x1 and y0 != y1", value);
        t->has_area = true;
        return 1;
    }
    if (!strncmp(name, "calib_", 6) && name[6] >= '1' && name[6] <= '3' && !name[7]) {
        unsigned k = (unsigned)(name[6] - '1');
        if (parse_doubles(value, t->calib[k], 4))
            return bad(c, section, name, "'%s' is not panel_x,panel_y,plate_x_m,plate_y_m", value);
        t->calib_set |= 1u << k;
        return 1;
    }
    if (!strcmp(name, "max_distance_m") || !strcmp(name, "hysteresis_m")) {
        bool max = name[0] == 'm';
        double v;
        if (parse_doubles(value, &v, 1) || (max ? !(v > 0 && v <= 10) : !(v >= 0 && v <= 1)))
            return bad(c, section, name, "'%s' is not a number in %s", value, max ? "(0, 10]" : "[0, 1]");
        *(max ? &t->max_distance_m : &t->hysteresis_m) = v;
        return 1;
    }
    return bad(c, section, name, "unknown key");
}

static int handler(void *user, const char *section, const char *name, const char *value)
{
    struct parse_ctx *c = user;
    struct hd_board *b = c->b;
    if (!strcmp(section, "alsa"))
        return alsa_key(c, section, name, value);
    if (!strncmp(section, "line ", 5))
        return line_key(c, section, name, value);
    if (!strcmp(section, "touch")) {
        b->touch.enabled = true;
        return touch_key(c, section, name, value);
    }
    if (!strcmp(section, "capture")) {
        b->capture.enabled = true;
        return capture_key(c, section, name, value);
    }
    if (!strcmp(section, "gpio")) {
        if (!strcmp(name, "chip"))
            return copy_str(c, section, name, b->gpio_chip, sizeof b->gpio_chip, value);
        if (!strcmp(name, "lockout_ms"))
            UINT_KEY(b->lockout_ms, 0, 10000);
        return bad(c, section, name, "unknown key");
    }
    if (!strcmp(section, "exciters")) {
        b->exciters.enabled = true;
        return exciters_key(c, section, name, value);
    }
    if (!strcmp(section, "control")) {
        if (!strcmp(name, "intensity_file")) {
            if (value[0] != '/')
                return bad(c, section, name, "'%s' is not an absolute path (e.g. /run/hapticd/intensity_db)", value);
            return copy_str(c, section, name, b->intensity_file, sizeof b->intensity_file, value);
        }
        return bad(c, section, name, "unknown key");
    }
    if (!strcmp(section, "amplifier")) {
        if (!strcmp(name, "full_scale_v"))
            return number_key(c, section, name, value, 0.0, false, 1000.0, &b->amp_full_scale_v);
        return bad(c, section, name, "unknown key");
    }
    if (!strcmp(section, "mixer")) {
        if (!strcmp(name, "gain_limit"))
            return number_key(c, section, name, value, 0.0, false, 16.0, &b->gain_limit);
        if (!strcmp(name, "max_foci"))
            UINT_KEY(b->max_foci, 1, HD_MAX_VOICE_FOCI);
        if (!strcmp(name, "foci_policy")) {
            if (!strcmp(value, "newest"))
                b->foci_policy = HD_FOCI_NEWEST;
            else if (!strcmp(value, "first"))
                b->foci_policy = HD_FOCI_FIRST;
            else
                return bad(c, section, name, "'%s' is not newest or first", value);
            return 1;
        }
        return bad(c, section, name, "unknown key");
    }
    if (!strcmp(section, "panel")) {
        struct hd_panel_board *p = &b->panel;
        if (!strcmp(name, "speed_ratio"))
            return number_key(c, section, name, value, HAPTIC_STRETCH_MIN_RATIO, true, HAPTIC_STRETCH_MAX_RATIO,
                              &p->speed_ratio);
        if (!strcmp(name, "temperature_input")) {
            if (value[0] != '/')
                return bad(c, section, name, "'%s' is not an absolute path (e.g. /sys/class/hwmon/hwmon0/temp1_input)",
                           value);
            return copy_str(c, section, name, p->temperature_input, sizeof p->temperature_input, value);
        }
        if (!strcmp(name, "temperature_poll_s"))
            return number_key(c, section, name, value, 0.2, true, 3600.0, &p->temperature_poll_s);
        if (!strcmp(name, "temperature_step_k"))
            return number_key(c, section, name, value, 0.0, false, 50.0, &p->temperature_step_k);
        return bad(c, section, name, "unknown key");
    }
    if (!strcmp(section, "table")) {
        if (!strcmp(name, "path"))
            return copy_path(c, section, name, b->table_path, value);
        return bad(c, section, name, "unknown key");
    }
    if (!strcmp(section, "realtime")) {
        if (!strcmp(name, "priority")) {
            unsigned long v;
            if (parse_uint(value, 0, 99, &v))
                return bad(c, section, name, "'%s' is not an integer in 0..99", value);
            b->rt_priority = (int)v;
            return 1;
        }
        if (!strcmp(name, "mlock")) {
            if (parse_bool(value, &b->mlock))
                return bad(c, section, name, "'%s' is not true or false", value);
            return 1;
        }
        return bad(c, section, name, "unknown key");
    }
    return bad(c, section[0] ? section : "(none)", name, "unknown section");
}

/* Checks that involve several keys; messages name the key they blame. */
static int cross_check(struct parse_ctx *c)
{
    struct hd_board *b = c->b;
    if (!b->alsa_device[0])
        return bad(c, "alsa", "device", "missing (required)");
    if (b->map_count > b->channels)
        return bad(c, "alsa", "channel_map", "%u entries but the device has %u channels", b->map_count, b->channels);
    for (unsigned i = 0; i < b->map_count; i++) {
        if (b->channel_map[i] >= b->channels)
            return bad(c, "alsa", "channel_map", "entry %u is ALSA channel %u, the device has 0..%u", i,
                       b->channel_map[i], b->channels - 1);
        for (unsigned j = 0; j < i; j++)
            if (b->channel_map[j] == b->channel_map[i])
                return bad(c, "alsa", "channel_map", "ALSA channel %u appears twice", b->channel_map[i]);
    }
    for (unsigned i = 0; i < b->line_count; i++) {
        char sec[32];
        snprintf(sec, sizeof sec, "line %u", b->lines[i].offset);
        if (b->lines[i].focus_count == 0)
            return bad(c, sec, "foci", "missing (each line plays at least one focus)");
    }
    const struct hd_touch_board *t = &b->touch;
    if (t->enabled) {
        if (!t->device[0] == !t->name[0])
            return bad(c, "touch", "device", "give exactly one of [touch] device and [touch] name");
        if (t->calib_set && t->calib_set != 7)
            return bad(c, "touch", t->calib_set & 1 ? (t->calib_set & 2 ? "calib_3" : "calib_2") : "calib_1",
                       "missing (calib_1, calib_2 and calib_3 go together)");
        if (!t->calib_set && !t->has_area)
            return bad(c, "touch", "area_m", "missing: give area_m or calib_1..calib_3");
        if (t->calib_set) {
            double panel[6], plate[6];
            struct hd_touch_map m;
            for (int k = 0; k < 3; k++) {
                panel[2 * k] = t->calib[k][0];
                panel[2 * k + 1] = t->calib[k][1];
                plate[2 * k] = t->calib[k][2];
                plate[2 * k + 1] = t->calib[k][3];
            }
            if (hd_touch_map_from_points(panel, plate, &m))
                return bad(c, "touch", "calib_3",
                           "the three points give no finite map (collinear panel points, or a plate beyond range)");
        }
    }
    struct hd_capture_board *k = &b->capture;
    if (k->enabled) {
        if (!k->device[0])
            return bad(c, "capture", "device", "missing (the ALSA capture device --measure records)");
        if (!k->rate_hz)
            k->rate_hz = b->rate_hz;
        else if (k->rate_hz != b->rate_hz)
            return bad(c, "capture", "rate_hz",
                       "%u Hz but [alsa] rate_hz is %u: a sample-synchronous recording needs the playback's rate "
                       "(one clock)",
                       k->rate_hz, b->rate_hz);
    }
    if (b->line_count > 0 && !b->gpio_chip[0])
        return bad(c, "gpio", "chip", "missing but [line N] sections are present");
    const struct hd_exciters_board *e = &b->exciters;
    if (e->enabled) {
        if (!e->power_count)
            return bad(c, "exciters", "rated_power_w", "missing (the exciters' RMS power rating, W)");
        if (!e->impedance_count)
            return bad(c, "exciters", "impedance_ohm", "missing (the exciters' nominal impedance, ohm)");
        if (!(b->amp_full_scale_v > 0))
            return bad(c, "amplifier", "full_scale_v",
                       "missing: [exciters] needs the amplifier's output at full scale");
        const unsigned counts[] = {e->power_count, e->impedance_count, e->tau_count};
        const char *keys[] = {"rated_power_w", "impedance_ohm", "thermal_tau_s"};
        for (int k = 0; k < 3; k++)
            if (counts[k] > 1 && counts[k] != b->map_count)
                return bad(c, "exciters", keys[k], "%u values for %u exciters ([alsa] channel_map): give one or %u",
                           counts[k], b->map_count, b->map_count);
    } else if (b->amp_full_scale_v > 0) {
        return bad(c, "amplifier", "full_scale_v", "given without [exciters] ratings to enforce");
    }
    return 0;
}

int hd_board_exciter_ratings(const struct hd_board *b, struct hd_exciter_rating *out, unsigned n)
{
    const struct hd_exciters_board *e = &b->exciters;
    if (!e->enabled)
        return 0;
    for (unsigned k = 0; k < n; k++) {
        out[k].rated_power_w = e->rated_power_w[e->power_count > 1 ? k : 0];
        out[k].impedance_ohm = e->impedance_ohm[e->impedance_count > 1 ? k : 0];
        out[k].tau_s = e->tau_count ? e->tau_s[e->tau_count > 1 ? k : 0] : HD_PROTECT_DEFAULT_TAU_S;
    }
    return 1;
}

static void set_dir(struct parse_ctx *c, const char *path)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        strcpy(c->dir, ".");
    else if (slash == path)
        strcpy(c->dir, "/");
    else
        snprintf(c->dir, sizeof c->dir, "%.*s", (int)(slash - path), path);
}

static int finish(struct parse_ctx *c, int rc, const char *path, char err[HD_ERR_MAX])
{
    if (rc == 0 && !c->failed)
        cross_check(c);
    if (rc > 0 || c->failed) {
        if (rc > 0)
            snprintf(err, HD_ERR_MAX, "%.200s:%d: %.290s", path, rc, c->failed ? c->msg : "syntax error");
        else
            snprintf(err, HD_ERR_MAX, "%.200s: %.290s", path, c->msg);
        return -EINVAL;
    }
    if (rc < 0) {
        snprintf(err, HD_ERR_MAX, "%s: out of memory while parsing", path);
        return -ENOMEM;
    }
    return 0;
}

/* Every line is text and fits the ini reader whole. inih reads a line into a
 * fixed buffer and parses what does not fit as a line of its own (a long
 * comment's tail "periods = 32" would take effect), and its line numbers
 * count those pieces; so a line longer than HD_BOARD_LINE_MAX is refused
 * here, naming its true line, before inih sees the file. */
static int check_lines(const char *text, size_t len, const char *path, char err[HD_ERR_MAX])
{
    unsigned no = 0;
    for (size_t at = 0; at < len;) {
        const char *nl = memchr(text + at, '\n', len - at);
        size_t n = nl ? (size_t)(nl - (text + at)) : len - at;
        size_t column;
        const char *what;
        no++;
        if (n > HD_BOARD_LINE_MAX) {
            snprintf(err, HD_ERR_MAX, "%.400s:%u: line of %zu bytes, longer than %u (not a board file line)", path, no,
                     n, HD_BOARD_LINE_MAX);
            return -EINVAL;
        }
        if ((what = hd_text_check_line(text + at, n, &column))) {
            snprintf(err, HD_ERR_MAX, "%.400s:%u: %s at column %zu (a board file is UTF-8 text)", path, no, what,
                     column);
            return -EINVAL;
        }
        at += n + 1;
    }
    return 0;
}

static int parse_text(const char *text, size_t len, const char *path, struct hd_board *b, char err[HD_ERR_MAX])
{
    struct parse_ctx c = {.b = b};
    hd_board_defaults(b);
    snprintf(b->path, sizeof b->path, "%s", path);
    set_dir(&c, path);
    int rc = check_lines(text, len, path, err);
    if (rc)
        return rc;
    return finish(&c, ini_parse_string(text, handler, &c), path, err);
}

int hd_board_parse_string(const char *text, const char *path, struct hd_board *b, char err[HD_ERR_MAX])
{
    return parse_text(text, strlen(text), path, b, err);
}

int hd_board_load(const char *path, struct hd_board *b, char err[HD_ERR_MAX])
{
    hd_board_defaults(b);
    if (strlen(path) >= sizeof b->path) {
        snprintf(err, HD_ERR_MAX, "%.100s...: board path too long", path);
        return -ENAMETOOLONG;
    }
    /* Opened without blocking (a FIFO at the path would block fopen) and
     * refused unless it is a regular file: a directory, a FIFO or a device
     * such as /dev/zero is no board file, and reading one could not end.
     * Read whole, bounded before allocating: a board file is a page of text. */
    int fd;
    haptic_file_status fs;
    int rc = haptic_file_open_regular(path, HD_BOARD_MAX_BYTES, &fd, &fs);
    if (fs.refusal == HAPTIC_FILE_CANNOT_OPEN)
        snprintf(err, HD_ERR_MAX, "%s: cannot open board file: %s", path, strerror(fs.error));
    else if (fs.refusal == HAPTIC_FILE_NOT_REGULAR)
        snprintf(err, HD_ERR_MAX, "%s: not a regular file (a %s is no board file)", path,
                 haptic_file_kind_name(fs.kind));
    else if (fs.refusal == HAPTIC_FILE_TOO_BIG)
        snprintf(err, HD_ERR_MAX, "%s: %lld bytes, larger than the %u a board file may have", path, (long long)fs.size,
                 HD_BOARD_MAX_BYTES);
    if (rc)
        return rc;
    const size_t size = (size_t)fs.size;
    char *text = malloc(size + 1);
    size_t got = 0;
    int e = text ? 0 : ENOMEM;
    while (!e && got < size) {
        ssize_t n = read(fd, text + got, size - got);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0)
            e = n < 0 ? errno : EIO; /* shrank while read */
        else
            got += (size_t)n;
    }
    close(fd);
    if (e) {
        free(text);
        snprintf(err, HD_ERR_MAX, "%s: cannot read board file: %s", path, strerror(e));
        return -e;
    }
    text[got] = '\0';
    rc = parse_text(text, got, path, b, err);
    free(text);
    return rc;
}
