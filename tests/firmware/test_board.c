/* board.ini: every key, and every bad value gives a one-line error naming the file and the key. */
#define _POSIX_C_SOURCE 200809L /* mkdtemp, mkfifo */
#include "board.h"
#include "protect.h"

#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <cmocka.h>

static const char *full = "[alsa]\n"
                          "device = hw:CARD=Device,DEV=0\n"
                          "config = my.asoundrc\n"
                          "channels = 10\n"
                          "format = S16_LE\n"
                          "rate_hz = 44100\n"
                          "period_frames = 32\n"
                          "periods = 3\n"
                          "channel_map = 9, 8,7,6,5,4,3,2\n"
                          "pacing = clock\n"
                          "rewind = false\n"
                          "rewind_margin_frames = 48\n"
                          "[gpio]\n"
                          "chip = gpiochip4\n"
                          "lockout_ms = 120\n"
                          "[line 17]\n"
                          "foci = 3\n"
                          "active_low = true\n"
                          "bias = pull-up\n"
                          "[line 27]\n"
                          "foci = 1, 4,4000000000\n"
                          "active_low = no\n"
                          "bias = pull-down\n"
                          "[line 5]\n"
                          "foci = 2\n"
                          "bias = disable\n"
                          "[mixer]\n"
                          "gain_limit = 0.5\n"
                          "max_foci = 3\n"
                          "foci_policy = first\n"
                          "[exciters]\n"
                          "rated_power_w = 3, 3, 3, 3, 2, 2, 2, 2.5\n"
                          "impedance_ohm = 4\n"
                          "thermal_tau_s = 1.5\n"
                          "[amplifier]\n"
                          "full_scale_v = 8.5\n"
                          "[panel]\n"
                          "speed_ratio = 0.987\n"
                          "temperature_input = /sys/class/hwmon/hwmon2/temp1_input\n"
                          "temperature_poll_s = 2.5\n"
                          "temperature_step_k = 0.25\n"
                          "[table]\n"
                          "path = /var/lib/hapticd/plate.htab\n"
                          "[realtime]\n"
                          "priority = 70\n"
                          "mlock = off\n";

static void every_key(void **state)
{
    (void)state;
    struct hd_board b;
    char err[HD_ERR_MAX] = "";
    assert_int_equal(hd_board_parse_string(full, "boards/x/board.ini", &b, err), 0);
    assert_string_equal(b.alsa_device, "hw:CARD=Device,DEV=0");
    assert_string_equal(b.alsa_config, "boards/x/my.asoundrc");
    assert_int_equal(b.channels, 10);
    assert_int_equal(b.format, HD_FMT_S16_LE);
    assert_int_equal(b.rate_hz, 44100);
    assert_int_equal(b.period_frames, 32);
    assert_int_equal(b.periods, 3);
    assert_int_equal(b.map_count, 8);
    for (unsigned i = 0; i < 8; i++)
        assert_int_equal(b.channel_map[i], 9 - i);
    assert_int_equal(b.pacing, HD_PACE_CLOCK);
    assert_false(b.rewind);
    assert_int_equal(b.rewind_margin_frames, 48);
    assert_string_equal(b.gpio_chip, "gpiochip4");
    assert_int_equal(b.lockout_ms, 120);
    assert_int_equal(b.line_count, 3);
    assert_int_equal(b.lines[0].offset, 17);
    assert_true(b.lines[0].active_low);
    assert_int_equal(b.lines[0].bias, HD_BIAS_PULL_UP);
    assert_int_equal(b.lines[0].focus_count, 1);
    assert_int_equal(b.lines[0].focus_ids[0], 3);
    assert_int_equal(b.lines[1].offset, 27);
    assert_false(b.lines[1].active_low);
    assert_int_equal(b.lines[1].bias, HD_BIAS_PULL_DOWN);
    assert_int_equal(b.lines[1].focus_count, 3);
    assert_int_equal(b.lines[1].focus_ids[2], 4000000000u);
    assert_int_equal(b.lines[2].offset, 5);
    assert_false(b.lines[2].active_low);
    assert_int_equal(b.lines[2].bias, HD_BIAS_DISABLE);
    assert_true(b.gain_limit == 0.5);
    assert_int_equal(b.max_foci, 3);
    assert_int_equal(b.foci_policy, HD_FOCI_FIRST);
    /* Ratings per exciter, the one-value forms spread over all 8. */
    struct hd_exciter_rating r[8];
    assert_int_equal(hd_board_exciter_ratings(&b, r, 8), 1);
    assert_true(r[0].rated_power_w == 3 && r[4].rated_power_w == 2 && r[7].rated_power_w == 2.5);
    for (unsigned k = 0; k < 8; k++)
        assert_true(r[k].impedance_ohm == 4 && r[k].tau_s == 1.5);
    assert_true(b.amp_full_scale_v == 8.5);
    assert_true(b.panel.speed_ratio == 0.987);
    assert_string_equal(b.panel.temperature_input, "/sys/class/hwmon/hwmon2/temp1_input");
    assert_true(b.panel.temperature_poll_s == 2.5 && b.panel.temperature_step_k == 0.25);
    assert_string_equal(b.table_path, "/var/lib/hapticd/plate.htab");
    assert_int_equal(b.rt_priority, 70);
    assert_false(b.mlock);
}

static void defaults(void **state)
{
    (void)state;
    struct hd_board b;
    char err[HD_ERR_MAX] = "";
    assert_int_equal(hd_board_parse_string("[alsa]\ndevice = hw:0\n", "b.ini", &b, err), 0);
    assert_int_equal(b.channels, 8);
    assert_int_equal(b.format, HD_FMT_S32_LE);
    assert_int_equal(b.rate_hz, 48000);
    assert_int_equal(b.period_frames, 64);
    assert_int_equal(b.periods, 2);
    assert_int_equal(b.map_count, 8);
    for (unsigned i = 0; i < 8; i++)
        assert_int_equal(b.channel_map[i], i);
    assert_int_equal(b.pacing, HD_PACE_DEVICE);
    assert_true(b.rewind);
    assert_int_equal(b.rewind_margin_frames, 32);
    assert_int_equal(b.line_count, 0);
    assert_true(b.gain_limit == 1.0);
    assert_int_equal(b.max_foci, 2);
    assert_int_equal(b.foci_policy, HD_FOCI_NEWEST);
    struct hd_exciter_rating r[8];
    assert_int_equal(hd_board_exciter_ratings(&b, r, 8), 0); /* no [exciters]: not protected */
    assert_true(b.panel.speed_ratio == 1.0);
    assert_string_equal(b.panel.temperature_input, "");
    assert_true(b.panel.temperature_poll_s == 10.0 && b.panel.temperature_step_k == 0.5);
    assert_string_equal(b.table_path, "");
    assert_string_equal(b.alsa_config, "");
    assert_int_equal(b.rt_priority, 80);
    assert_true(b.mlock);
}

struct bad_case {
    const char *text;  /* appended after a valid [alsa] device line unless it starts with '!' */
    const char *names; /* what the message must contain */
    int line;          /* expected line number in the message, 0: none */
};

static const struct bad_case cases[] = {
    {"[alsa]\nchannels = 0\n", "[alsa] channels", 4},
    {"[alsa]\nchannels = 33\n", "[alsa] channels", 4},
    {"[alsa]\nchannels = eight\n", "[alsa] channels", 4},
    {"[alsa]\nchannels = -8\n", "[alsa] channels", 4},
    {"[alsa]\nrate_hz = 7999\n", "[alsa] rate_hz", 4},
    {"[alsa]\nrate_hz = 48k\n", "[alsa] rate_hz", 4},
    {"[alsa]\nrate_hz = 99999999999999999999999\n", "[alsa] rate_hz", 4},
    {"[alsa]\nperiod_frames = 8\n", "[alsa] period_frames", 4},
    {"[alsa]\nperiods = 1\n", "[alsa] periods", 4},
    {"[alsa]\nperiods = 33\n", "[alsa] periods", 4},
    {"[alsa]\nformat = S24_LE\n", "[alsa] format", 4},
    {"[alsa]\nchannel_map = 0,x\n", "[alsa] channel_map", 4},
    {"[alsa]\nchannel_map = 0,,1\n", "[alsa] channel_map", 4},
    {"[alsa]\nchannel_map = 32\n", "[alsa] channel_map", 4},
    {"[alsa]\nchannel_map = 0,1,1\n", "[alsa] channel_map", 0},
    {"[alsa]\nchannel_map = 0,1,2,3,4,5,6,7,8\n", "[alsa] channel_map", 0},
    {"[alsa]\nchannels = 4\nchannel_map = 0,1,2,5\n", "[alsa] channel_map", 0},
    {"[alsa]\npacing = fast\n", "[alsa] pacing", 4},
    {"[alsa]\nrewind = maybe\n", "[alsa] rewind", 4},
    {"[alsa]\nrewind_margin_frames = 8193\n", "[alsa] rewind_margin_frames", 4},
    {"[alsa]\nrewind_margin_frames = -1\n", "[alsa] rewind_margin_frames", 4},
    {"[alsa]\nconfig =\n", "[alsa] config", 4},
    {"[alsa]\nvolume = 3\n", "[alsa] volume", 4},
    {"!device =\n", "[alsa] device", 1},
    {"!channels = 8\n", "[alsa] device", 0},
    {"[gpio]\nchip = gpiochip0\nlockout_ms = 10001\n", "[gpio] lockout_ms", 5},
    {"[gpio]\nlockout_ms = -1\n", "[gpio] lockout_ms", 4},
    {"[gpio]\nbounce = 3\n", "[gpio] bounce", 4},
    {"[gpio]\nchip = 0\n[line 3]\nfoci = \n", "[line 3] foci", 6},
    {"[gpio]\nchip = 0\n[line 3]\nfoci = a\n", "[line 3] foci", 6},
    {"[gpio]\nchip = 0\n[line 3]\nfoci = 1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17\n", "[line 3] foci", 6},
    {"[gpio]\nchip = 0\n[line 3]\nfoci = 4294967296\n", "[line 3] foci", 6},
    {"[gpio]\nchip = 0\n[line 3]\nfoci = 1\nactive_low = maybe\n", "[line 3] active_low", 7},
    {"[gpio]\nchip = 0\n[line 3]\nfoci = 1\nbias = up\n", "[line 3] bias", 7},
    {"[gpio]\nchip = 0\n[line 3]\nfoci = 1\nedge = both\n", "[line 3] edge", 7},
    {"[gpio]\nchip = 0\n[line 3]\nbias = pull-up\n", "[line 3] foci", 0},
    {"[gpio]\nchip = 0\n[line x]\nfoci = 1\n", "[line x] foci", 6},
    {"[touch]\ndevice = event0\n", "[touch] device", 4},
    {"[touch]\narea_m = 0,0,0.7\n", "[touch] area_m", 4},
    {"[touch]\narea_m = 0,0,0,0.7\n", "[touch] area_m", 4},
    {"[touch]\narea_m = 0,0,0.7,0.7,1\n", "[touch] area_m", 4},
    {"[touch]\narea_m = -1e308,0,1e308,1\n", "[touch] area_m", 4},
    {"[touch]\nname = p\ncalib_1 = 0,0,1e308,0\ncalib_2 = 1,0,-1e308,0\ncalib_3 = 0,1,0,0\n", "no finite map", 0},
    {"[touch]\ncalib_1 = 0,0,x,0\n", "[touch] calib_1", 4},
    {"[touch]\ncalib_4 = 0,0,0,0\n", "[touch] calib_4", 4},
    {"[touch]\nmax_distance_m = 0\n", "[touch] max_distance_m", 4},
    {"[touch]\nmax_distance_m = nan\n", "[touch] max_distance_m", 4},
    {"[touch]\nhysteresis_m = -0.001\n", "[touch] hysteresis_m", 4},
    {"[touch]\nswap = 1\n", "[touch] swap", 4},
    {"[touch]\narea_m = 0,0,0.7,0.7\n", "[touch] device", 0},
    {"[touch]\ndevice = /dev/input/event0\nname = ft5x06\narea_m = 0,0,0.7,0.7\n", "[touch] device", 0},
    {"[touch]\nname = ft5x06\n", "[touch] area_m", 0},
    {"[touch]\nname = ft5x06\ncalib_1 = 0,0,0,0\ncalib_3 = 1,0,1,0\n", "[touch] calib_2", 0},
    {"[touch]\nname = ft5x06\ncalib_1 = 0,0,0,0\ncalib_2 = 1,1,1,0\ncalib_3 = 2,2,0,1\n", "[touch] calib_3", 0},
    {"[gpio]\nchip = 0\n[line 1024]\nfoci = 1\n", "[line 1024] foci", 6},
    {"[line 3]\nfoci = 1\n", "[gpio] chip", 0},
    {"[mixer]\ngain_limit = 0\n", "[mixer] gain_limit", 4},
    {"[mixer]\nmax_foci = 0\n", "[mixer] max_foci", 4},
    {"[mixer]\nmax_foci = 33\n", "[mixer] max_foci", 4},
    {"[mixer]\nfoci_policy = strongest\n", "[mixer] foci_policy", 4},
    {"[exciters]\nrated_power_w = 0\n", "[exciters] rated_power_w", 4},
    {"[exciters]\nrated_power_w = 3,,3\n", "[exciters] rated_power_w", 4},
    {"[exciters]\nimpedance_ohm = -4\n", "[exciters] impedance_ohm", 4},
    {"[exciters]\nthermal_tau_s = inf\n", "[exciters] thermal_tau_s", 4},
    {"[exciters]\nwatts = 3\n", "[exciters] watts", 4},
    {"[exciters]\nimpedance_ohm = 4\n[amplifier]\nfull_scale_v = 10\n", "[exciters] rated_power_w", 0},
    {"[exciters]\nrated_power_w = 3\n[amplifier]\nfull_scale_v = 10\n", "[exciters] impedance_ohm", 0},
    {"[exciters]\nrated_power_w = 3\nimpedance_ohm = 4\n", "[amplifier] full_scale_v", 0},
    {"[exciters]\nrated_power_w = 3,3\nimpedance_ohm = 4\n[amplifier]\nfull_scale_v = 10\n", "2 values for 8 exciters",
     0},
    {"[amplifier]\nfull_scale_v = 10\n", "given without [exciters]", 0},
    {"[amplifier]\nfull_scale_v = 0\n", "[amplifier] full_scale_v", 4},
    {"[mixer]\ngain_limit = 17\n", "[mixer] gain_limit", 4},
    {"[mixer]\ngain_limit = nan\n", "[mixer] gain_limit", 4},
    {"[mixer]\ngain_limit = 1x\n", "[mixer] gain_limit", 4},
    {"[panel]\nspeed_ratio = 0.79\n", "[panel] speed_ratio", 4},
    {"[panel]\nspeed_ratio = 1.26\n", "[panel] speed_ratio", 4},
    {"[panel]\nspeed_ratio = fast\n", "[panel] speed_ratio", 4},
    {"[panel]\ntemperature_input = hwmon0/temp1_input\n", "[panel] temperature_input", 4},
    {"[panel]\ntemperature_poll_s = 0\n", "[panel] temperature_poll_s", 4},
    {"[panel]\ntemperature_step_k = 0\n", "[panel] temperature_step_k", 4},
    {"[panel]\ntemperature_step_k = inf\n", "[panel] temperature_step_k", 4},
    {"[panel]\nmodulus = 1\n", "[panel] modulus", 4},
    {"[table]\npath =\n", "[table] path", 4},
    {"[table]\nfile = x\n", "[table] file", 4},
    {"[realtime]\npriority = 100\n", "[realtime] priority", 4},
    {"[realtime]\nmlock = sometimes\n", "[realtime] mlock", 4},
    {"[realtime]\nnice = 1\n", "[realtime] nice", 4},
    {"[audio]\nx = 1\n", "[audio] x", 4},
    {"[capture]\nchannels = 2\n", "[capture] device", 0},
    {"[capture]\ndevice =\n", "[capture] device", 4},
    {"[capture]\ndevice = hw:0\nchannels = 0\n", "[capture] channels", 5},
    {"[capture]\ndevice = hw:0\nchannels = 33\n", "[capture] channels", 5},
    {"[capture]\ndevice = hw:0\nformat = FLOAT_LE\n", "[capture] format", 5},
    {"[capture]\ndevice = hw:0\nrate_hz = 7999\n", "[capture] rate_hz", 5},
    {"[capture]\ndevice = hw:0\nrate_hz = 44100\n", "[capture] rate_hz", 0},
    {"[capture]\ndevice = hw:0\noffset_frames = -1\n", "[capture] offset_frames", 5},
    {"[capture]\ndevice = hw:0\noffset_frames = 65537\n", "[capture] offset_frames", 5},
    {"[capture]\ndevice = hw:0\nplayback_device =\n", "[capture] playback_device", 5},
    {"[capture]\ndevice = hw:0\ngain = 1\n", "[capture] gain", 5},
    {"[alsa]\nthis is not ini\n", "syntax error", 4},
};

static void bad_values(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char text[1024];
        if (cases[i].text[0] == '!')
            snprintf(text, sizeof text, "[alsa]\n%s", cases[i].text + 1);
        else
            snprintf(text, sizeof text, "[alsa]\ndevice = hw:0\n\n%s", cases[i].text);
        struct hd_board b;
        char err[HD_ERR_MAX] = "";
        int rc = hd_board_parse_string(text, "boards/t/board.ini", &b, err);
        if (rc != -EINVAL || !strstr(err, cases[i].names) || strchr(err, '\n') ||
            strncmp(err, "boards/t/board.ini", 18) != 0)
            fail_msg("case %zu (%s): rc %d, message '%s'", i, cases[i].names, rc, err);
        if (cases[i].line) {
            char want[64];
            snprintf(want, sizeof want, "boards/t/board.ini:%d: ", cases[i].line + 1);
            if (strncmp(err, want, strlen(want)) != 0)
                fail_msg("case %zu: expected '%s' prefix, got '%s'", i, want, err);
        }
    }
}

static void missing_file(void **state)
{
    (void)state;
    struct hd_board b;
    char err[HD_ERR_MAX] = "";
    assert_int_equal(hd_board_load("/nonexistent/dir/board.ini", &b, err), -ENOENT);
    assert_non_null(strstr(err, "/nonexistent/dir/board.ini"));
    assert_null(strchr(err, '\n'));
}

/* A board path that is not a regular file is refused in one line, at once:
 * a FIFO (fopen would block until a writer came; the alarm makes a hang a
 * failure), a directory (it used to report a missing key), a device that
 * never ends (/dev/zero spun forever). */
static void refuses_what_is_not_a_regular_file(void **state)
{
    (void)state;
    char dir[] = "/tmp/hd-board-XXXXXX";
    assert_non_null(mkdtemp(dir));
    char fifo[64];
    snprintf(fifo, sizeof fifo, "%s/board.ini", dir);
    assert_int_equal(mkfifo(fifo, 0600), 0);
    const char *paths[] = {fifo, dir, "/dev/zero"};
    alarm(10);
    for (size_t i = 0; i < sizeof paths / sizeof paths[0]; i++) {
        struct hd_board b;
        char err[HD_ERR_MAX] = "";
        assert_int_equal(hd_board_load(paths[i], &b, err), -EINVAL);
        assert_non_null(strstr(err, paths[i]));
        assert_non_null(strstr(err, "not a regular file"));
        assert_null(strchr(err, '\n'));
    }
    alarm(0);
    assert_int_equal(unlink(fifo), 0);
    assert_int_equal(rmdir(dir), 0);
}

/* Lines the ini reader cannot hold whole, and bytes that are not text, are
 * refused naming their true line; a line of exactly HD_BOARD_LINE_MAX bytes
 * is read whole. Before, a comment of 200+ bytes had its tail parsed as a
 * setting ("... periods = 32" set the buffer to 42.7 ms) and a 1 MB value
 * line was blamed on a line past the file's end. */
static void long_lines_and_raw_bytes_are_refused_on_their_line(void **state)
{
    (void)state;
    static char text[1200000];
    struct hd_board b;
    char err[HD_ERR_MAX];
    /* A comment whose tail, cut by inih, would read "periods = 32". */
    for (unsigned len = HD_BOARD_LINE_MAX; len <= HD_BOARD_LINE_MAX + 60; len += 60) {
        static const char head[] = "[alsa]\ndevice = hw:0\n", comment[] = "; old setting kept for reference ";
        const size_t dashes = len - (sizeof comment - 1) - strlen("periods = 32");
        int n = snprintf(text, sizeof text, "%s%s", head, comment);
        memset(text + n, '-', dashes);
        snprintf(text + n + dashes, sizeof text - (size_t)n - dashes, "periods = 32\nperiods = 3\n");
        err[0] = '\0';
        int rc = hd_board_parse_string(text, "t/board.ini", &b, err);
        if (len == HD_BOARD_LINE_MAX) {
            if (rc != 0)
                fail_msg("a %u-byte comment refused: %s", len, err);
            assert_int_equal(b.periods, 3);
        } else {
            assert_int_equal(rc, -EINVAL);
            char want[128];
            snprintf(want, sizeof want, "t/board.ini:3: line of %u bytes, longer than %u", len, HD_BOARD_LINE_MAX);
            assert_non_null(strstr(err, want));
        }
    }
    /* A 1 MB value on line 2 of a 3-line file: line 2. */
    int n = snprintf(text, sizeof text, "[alsa]\ndevice = ");
    memset(text + n, 'x', 1000000);
    strcpy(text + n + 1000000, "\nperiods = 3\n");
    assert_int_equal(hd_board_parse_string(text, "t/board.ini", &b, err), -EINVAL);
    assert_non_null(strstr(err, "t/board.ini:2: line of 1000009 bytes"));
    static const struct {
        const char *text, *want;
    } raw[] = {
        {"[alsa]\ndevice = hw:0\x1b[2J\n", "t/board.ini:2: a control byte at column 14"},
        {"[alsa]\n\ndevice = caf\xe9\n", "t/board.ini:3: a byte that is not UTF-8 at column 13"},
        {"[alsa]\n; \xc0\xaf overlong\n", "t/board.ini:2: a byte that is not UTF-8 at column 3"},
        {"[alsa]\ndevice = hw:0\x7f\n", "t/board.ini:2: a control byte at column 14"},
        {"[alsa]\ndevice = hw:0\xc2\x9b\n", "t/board.ini:2: a control byte at column 14"}, /* C1 CSI */
    };
    for (size_t i = 0; i < sizeof raw / sizeof raw[0]; i++) {
        err[0] = '\0';
        assert_int_equal(hd_board_parse_string(raw[i].text, "t/board.ini", &b, err), -EINVAL);
        if (!strstr(err, raw[i].want))
            fail_msg("case %zu: '%s'", i, err);
    }
    /* UTF-8 text, tabs and CRLF line ends are text. */
    assert_int_equal(
        hd_board_parse_string("; caf\xc3\xa9 \xe2\x80\x94 ok\r\n[alsa]\r\n\tdevice = hw:0\r\n", "t/board.ini", &b, err),
        0);
}

/* A NUL in a board file (hd_board_load: the file's own bytes, not a C
 * string) and a file larger than a board file may be: refused in one line. */
static void nul_bytes_and_huge_files_are_refused(void **state)
{
    (void)state;
    char dir[] = "/tmp/hd-board-XXXXXX";
    assert_non_null(mkdtemp(dir));
    char path[64];
    snprintf(path, sizeof path, "%s/board.ini", dir);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fwrite("[alsa]\ndevice = hw:0\0periods = 3\n", 1, 34, f);
    fclose(f);
    struct hd_board b;
    char err[HD_ERR_MAX] = "";
    assert_int_equal(hd_board_load(path, &b, err), -EINVAL);
    assert_non_null(strstr(err, "board.ini:2: a NUL byte at column 14"));
    assert_int_equal(truncate(path, (off_t)HD_BOARD_MAX_BYTES + 1), 0);
    assert_int_equal(hd_board_load(path, &b, err), -EFBIG);
    assert_non_null(strstr(err, "larger than the 262144 a board file may have"));
    assert_int_equal(unlink(path), 0);
    assert_int_equal(hd_board_load(dir, &b, err), -EINVAL);
    assert_non_null(strstr(err, "(a directory is no board file)"));
    assert_int_equal(rmdir(dir), 0);
}

static void shipped_boards_parse(void **state)
{
    (void)state;
    static const char *const names[] = {"host-sim", "usb-8ch", "rpi5-dac8x", "bbb-mcasp-tdm8"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        char path[HD_PATH_MAX];
        snprintf(path, sizeof path, "%s/%s/board.ini", BOARDS_DIR, names[i]);
        struct hd_board b;
        char err[HD_ERR_MAX] = "";
        if (hd_board_load(path, &b, err) != 0)
            fail_msg("%s", err);
        assert_int_equal(b.map_count, 8);
        assert_int_equal(b.rate_hz, 48000);
        /* The default: 64 frames x 2 periods at 48 kHz (2.7 ms). */
        assert_int_equal(b.period_frames, 64);
        assert_int_equal(b.periods, 2);
        if (i == 0) {
            assert_int_equal(b.pacing, HD_PACE_CLOCK);
            assert_int_equal(b.line_count, 0);
            assert_non_null(strstr(b.alsa_config, "boards/host-sim/asoundrc"));
            /* --measure's loopback (asoundrc) */
            assert_true(b.capture.enabled);
            assert_string_equal(b.capture.device, "hostsim_capture");
            assert_string_equal(b.capture.playback_device, "hostsim_loop");
            assert_int_equal(b.capture.channels, 8);
        } else {
            assert_int_equal(b.pacing, HD_PACE_DEVICE);
            assert_true(b.line_count >= 3);
            assert_true(strncmp(b.alsa_device, "hw:", 3) == 0); /* hw:, never dmix */
        }
        assert_int_equal(b.touch.enabled, i == 2); /* the Pi 5 example has a touchscreen */
        if (b.touch.enabled) {
            /* Its three corners map the 800 x 480 screen onto 154.2 x 85.9 mm of plate. */
            assert_int_equal(b.touch.calib_set, 7);
            assert_true(fabs(b.touch.calib[0][2] - b.touch.calib[1][2] - 0.1542) < 1e-9);
            assert_true(fabs(b.touch.calib[0][3] - b.touch.calib[2][3] - 0.0859) < 1e-9);
        }
    }
}

/* [capture]: every key; the rate defaults to the playback's; a board without it stays valid. */
static void capture_section(void **state)
{
    (void)state;
    struct hd_board b;
    char err[HD_ERR_MAX] = "";
    assert_int_equal(hd_board_parse_string("[alsa]\ndevice = hw:0\nrate_hz = 44100\n[capture]\ndevice = hw:0,1\n"
                                           "playback_device = duplex\nchannels = 2\nformat = S16_LE\n"
                                           "offset_frames = 37\n",
                                           "b.ini", &b, err),
                     0);
    assert_true(b.capture.enabled);
    assert_string_equal(b.capture.device, "hw:0,1");
    assert_string_equal(b.capture.playback_device, "duplex");
    assert_int_equal(b.capture.channels, 2);
    assert_int_equal(b.capture.format, HD_FMT_S16_LE);
    assert_int_equal(b.capture.rate_hz, 44100);
    assert_int_equal(b.capture.offset_frames, 37);
    assert_int_equal(
        hd_board_parse_string("[alsa]\ndevice = hw:0\n[capture]\ndevice = hw:0\nrate_hz = 48000\n", "b.ini", &b, err),
        0);
    assert_int_equal(b.capture.channels, 8);
    assert_int_equal(b.capture.format, HD_FMT_S32_LE);
    assert_int_equal(b.capture.offset_frames, 0);
    assert_string_equal(b.capture.playback_device, "");
    assert_int_equal(hd_board_parse_string("[alsa]\ndevice = hw:0\n", "b.ini", &b, err), 0);
    assert_false(b.capture.enabled);
}

static void touch_section(void **state)
{
    (void)state;
    struct hd_board b;
    char err[HD_ERR_MAX] = "";
    assert_int_equal(hd_board_parse_string("[alsa]\ndevice = hw:0\n[touch]\nname = ILITEK Multi-Touch\n"
                                           "calib_1 = 0, 0, 0.010, 0.690\ncalib_2 = 4000,0,0.690,0.690\n"
                                           "calib_3 = 0,3000,0.010,0.010\nmax_distance_m = 0.08\n"
                                           "hysteresis_m = 0\n",
                                           "b.ini", &b, err),
                     0);
    assert_true(b.touch.enabled);
    assert_string_equal(b.touch.name, "ILITEK Multi-Touch");
    assert_string_equal(b.touch.device, "");
    assert_int_equal(b.touch.calib_set, 7);
    assert_true(b.touch.calib[1][0] == 4000 && b.touch.calib[1][2] == 0.690 && b.touch.calib[2][3] == 0.010);
    assert_true(b.touch.max_distance_m == 0.08 && b.touch.hysteresis_m == 0);
    assert_int_equal(hd_board_parse_string("[alsa]\ndevice = hw:0\n[touch]\ndevice = /dev/input/event3\n"
                                           "area_m = 0.7, 0, 0, 0.5\n",
                                           "b.ini", &b, err),
                     0);
    assert_string_equal(b.touch.device, "/dev/input/event3");
    assert_true(b.touch.has_area && b.touch.area_m[0] == 0.7 && b.touch.area_m[3] == 0.5);
    assert_true(b.touch.max_distance_m == 0.05 && b.touch.hysteresis_m == 0.005); /* defaults */
    assert_int_equal(hd_board_parse_string("[alsa]\ndevice = hw:0\n", "b.ini", &b, err), 0);
    assert_false(b.touch.enabled);
}

static void uint_list(void **state)
{
    (void)state;
    uint32_t v[4];
    assert_int_equal(hd_parse_uint_list("1", v, 4, 10), 1);
    assert_int_equal(hd_parse_uint_list(" 1 , 2,3 ", v, 4, 10), 3);
    assert_int_equal(v[0] + v[1] + v[2], 6);
    assert_int_equal(hd_parse_uint_list("1,2,3,4,5", v, 4, 10), -EINVAL);
    assert_int_equal(hd_parse_uint_list("11", v, 4, 10), -EINVAL);
    assert_int_equal(hd_parse_uint_list("1,", v, 4, 10), -EINVAL);
    assert_int_equal(hd_parse_uint_list("", v, 4, 10), -EINVAL);
    assert_int_equal(hd_parse_uint_list("-1", v, 4, 10), -EINVAL);
    assert_int_equal(hd_parse_uint_list("1 2", v, 4, 10), -EINVAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(every_key),
        cmocka_unit_test(defaults),
        cmocka_unit_test(bad_values),
        cmocka_unit_test(missing_file),
        cmocka_unit_test(refuses_what_is_not_a_regular_file),
        cmocka_unit_test(long_lines_and_raw_bytes_are_refused_on_their_line),
        cmocka_unit_test(nul_bytes_and_huge_files_are_refused),
        cmocka_unit_test(uint_list),
        cmocka_unit_test(shipped_boards_parse),
        cmocka_unit_test(touch_section),
        cmocka_unit_test(capture_section),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
