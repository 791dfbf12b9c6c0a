/* board.h - a board description (board.ini, parsed with inih).
 *
 * Every key, its unit and its default are documented in docs/firmware.md.
 * Relative paths in the file are resolved against the board file's folder.
 * Errors are one line: "FILE:LINE: [section] key: what is wrong".
 */
#ifndef HD_BOARD_H
#define HD_BOARD_H

#include "hd_defs.h"

#include <stdbool.h>
#include <stdint.h>

enum hd_sample_format { HD_FMT_S16_LE = 1, HD_FMT_S32_LE = 2 };
enum hd_bias { HD_BIAS_AS_IS = 0, HD_BIAS_DISABLE, HD_BIAS_PULL_UP, HD_BIAS_PULL_DOWN };
enum hd_pacing { HD_PACE_DEVICE = 0, HD_PACE_CLOCK };

struct hd_line {
    unsigned offset; /* GPIO line offset on the chip */
    bool active_low; /* touch pulls the line low: the press edge is falling */
    enum hd_bias bias;
    unsigned focus_count;
    uint32_t focus_ids[HD_MAX_EVENT_FOCI]; /* table focus ids this line plays */
};

struct hd_board {
    char path[HD_PATH_MAX]; /* the board file itself (for messages) */
    /* [alsa] */
    char alsa_device[256];
    char alsa_config[HD_PATH_MAX]; /* optional local ALSA config (host-sim), "" if none */
    unsigned channels;             /* ALSA channel count */
    enum hd_sample_format format;
    unsigned rate_hz;
    unsigned period_frames;
    unsigned periods;
    unsigned map_count;                    /* = table channel count the board expects */
    unsigned channel_map[HD_MAX_CHANNELS]; /* exciter (table channel) -> ALSA channel */
    enum hd_pacing pacing;
    bool rewind;                   /* start a trigger at once by rewinding the queued frames */
    unsigned rewind_margin_frames; /* queued frames never rewound: the device may be reading them */
    /* [gpio] */
    char gpio_chip[64]; /* "" when the board has no GPIO triggers */
    unsigned lockout_ms;
    unsigned line_count;
    struct hd_line lines[HD_MAX_LINES];
    /* [touch] */
    struct hd_touch_board {
        bool enabled;             /* the section is present */
        char device[HD_PATH_MAX]; /* evdev node, or "" */
        char name[128];           /* or: match this in the device name, "" */
        bool has_area;
        double area_m[4];   /* x0, y0, x1, y1 */
        unsigned calib_set; /* bit k: calib_{k+1} given */
        double calib[3][4]; /* panel_x, panel_y, plate_x_m, plate_y_m */
        double max_distance_m;
        double hysteresis_m;
    } touch;
    /* [mixer] */
    double gain_limit; /* upper bound of the mix gain g (1 = table full scale) */
    unsigned max_foci; /* foci one voice plays at most: touches beyond it follow foci_policy */
    enum hd_foci_policy { HD_FOCI_NEWEST = 0, HD_FOCI_FIRST } foci_policy;
    /* [exciters] and [amplifier]: the ratings hapticd enforces (protect.h);
     * per exciter in the table's channel order, one value meaning all */
    struct hd_exciters_board {
        bool enabled; /* [exciters] is present */
        unsigned power_count, impedance_count, tau_count;
        double rated_power_w[HD_MAX_CHANNELS];
        double impedance_ohm[HD_MAX_CHANNELS];
        double tau_s[HD_MAX_CHANNELS];
    } exciters;
    double amp_full_scale_v; /* [amplifier] full_scale_v: peak volts at digital full scale; 0 if not given */
    /* [control] */
    char intensity_file[HD_PATH_MAX]; /* the user's intensity in dB (control.h), "" if none */
    /* [panel]: the panel the table plays on, against the plate it was
     * calibrated for (speed compensation, panel.h) */
    struct hd_panel_board {
        double speed_ratio;                  /* how many times faster its response runs than the calibrated plate's, at
                                      the calibration temperature: a measured resonance over the same one of
                                      the calibrated plate (not a wave-speed ratio: that is its square root) */
        char temperature_input[HD_PATH_MAX]; /* file with its temperature in millidegrees C, "" if none */
        double temperature_poll_s;           /* how often that file is read */
        double temperature_step_k;           /* the drives are stretched again when it moved this much */
    } panel;
    /* [capture]: what `hapticd --measure` records, sample-synchronously
     * with the plan it plays (measure.h) */
    struct hd_capture_board {
        bool enabled;                 /* the section is present */
        char device[256];             /* ALSA capture PCM (through [alsa] config when given) */
        char playback_device[256];    /* the PCM the plan plays on; "" = [alsa] device */
        unsigned channels;            /* capture channels (sensors) */
        enum hd_sample_format format; /* of the device and of the recording */
        unsigned rate_hz;             /* must equal [alsa] rate_hz: one clock */
        unsigned offset_frames;       /* the converters' fixed lag: a played frame n is captured as frame n + offset */
    } capture;
    /* [table] */
    char table_path[HD_PATH_MAX]; /* "" if none (then --table is required) */
    /* [realtime] */
    int rt_priority; /* SCHED_FIFO priority of the audio thread, 0 = do not ask */
    bool mlock;
};

/* Foci one voice plays by default: two fingers. With the inverse filter
 * every pair of Fig. 7's foci passes the whole-area verdict and 4-8 of 84
 * triples fail; with time reversal 17 of 36 pairs fail already (docs/firmware.md,
 * "Several fingers"). */
#define HD_DEFAULT_MAX_FOCI 2u

/* Defaults for every key (64 frames x 2 periods, 48 kHz, S32_LE, 8 channels, identity map). */
void hd_board_defaults(struct hd_board *b);

/* A board file: at most HD_BOARD_MAX_BYTES, UTF-8 text, lines of at most
 * HD_BOARD_LINE_MAX bytes (the newline excluded): what the ini reader holds
 * whole (Debian's inih reads 199 bytes and a NUL). */
#define HD_BOARD_MAX_BYTES (256u * 1024u)
#define HD_BOARD_LINE_MAX 199u

/* Parse a board file. Returns 0, or -errno / -EINVAL with a one-line message in err. */
int hd_board_load(const char *path, struct hd_board *b, char err[HD_ERR_MAX]);

/* Parse board text held in memory; `path` is used for messages and relative paths. */
int hd_board_parse_string(const char *text, const char *path, struct hd_board *b, char err[HD_ERR_MAX]);

struct hd_exciter_rating;
/* The [exciters] ratings per table channel (exciter) k < n, the one-value
 * forms spread: 1 and *out filled, or 0 when the board has none. */
int hd_board_exciter_ratings(const struct hd_board *b, struct hd_exciter_rating *out, unsigned n);

/* Parse "1,4, 7" into at most `max` unsigned values (each <= limit). Returns the count or -EINVAL. */
int hd_parse_uint_list(const char *s, uint32_t *out, unsigned max, uint32_t limit);

const char *hd_format_name(enum hd_sample_format f);

#endif
