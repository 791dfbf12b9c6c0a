/* hapticd --measure, its pure parts: the WAV reader (16, 24, 32 bits,
 * WAVE_FORMAT_EXTENSIBLE, what it refuses) and the atomic writer; the plan
 * against the board (rate, channels, sample width, gain_limit); the
 * exciters' heat over a plan against hand-computed figures; the render
 * through the channel map. */
#define _GNU_SOURCE
#include "measure.h"
#include "wav.h"

#include <dirent.h>
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

static char dir[256];

static int setup(void **state)
{
    (void)state;
    const char *tmp = getenv("TMPDIR");
    snprintf(dir, sizeof dir, "%s/hapticd-measure-XXXXXX", tmp && *tmp ? tmp : "/tmp");
    return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

static void put16(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}
static void put32(uint8_t *p, uint32_t v)
{
    put16(p, v);
    put16(p + 2, v >> 16);
}

/* A WAV in memory: tag 1 or 0xFFFE (with the PCM GUID), an unknown chunk first. */
static size_t make_wav(uint8_t *out, unsigned tag, unsigned channels, unsigned rate, unsigned bits, const uint8_t *data,
                       size_t data_len)
{
    size_t at = 0;
    memcpy(out, "RIFF", 4);
    memcpy(out + 8, "WAVE", 4);
    at = 12;
    memcpy(out + at, "LIST", 4); /* skipped */
    put32(out + at + 4, 3);
    memcpy(out + at + 8, "abc\0", 4);
    at += 12;
    const unsigned fmt_len = tag == 0xFFFE ? 40 : 16;
    memcpy(out + at, "fmt ", 4);
    put32(out + at + 4, fmt_len);
    uint8_t *f = out + at + 8;
    memset(f, 0, fmt_len);
    put16(f, tag);
    put16(f + 2, channels);
    put32(f + 4, rate);
    put32(f + 8, rate * channels * bits / 8);
    put16(f + 12, channels * bits / 8);
    put16(f + 14, bits);
    if (tag == 0xFFFE) {
        put16(f + 16, 22);
        put16(f + 18, bits);
        put16(f + 24, 1); /* KSDATAFORMAT_SUBTYPE_PCM */
    }
    at += 8 + fmt_len;
    memcpy(out + at, "data", 4);
    put32(out + at + 4, (uint32_t)data_len);
    memcpy(out + at + 8, data, data_len);
    at += 8 + data_len;
    put32(out + 4, (uint32_t)(at - 8));
    return at;
}

static void wav_reader(void **state)
{
    (void)state;
    uint8_t buf[512], data[64];
    char err[HD_ERR_MAX];
    struct hd_wav w;
    /* 16 bits: -2, 32767, two channels, two frames */
    const int16_t s16[4] = {-2, 32767, -32768, 5};
    memcpy(data, s16, sizeof s16);
    size_t n = make_wav(buf, 1, 2, 48000, 16, data, sizeof s16);
    assert_int_equal(hd_wav_parse(buf, n, "a.wav", &w, err), 0);
    assert_int_equal(w.channels, 2);
    assert_int_equal(w.rate_hz, 48000);
    assert_int_equal(w.frames, 2);
    assert_int_equal(w.bits, 16);
    assert_int_equal(w.samples[0], -2 * 65536);
    assert_int_equal(w.samples[1], 32767 * 65536);
    assert_int_equal(w.samples[2], INT32_MIN);
    hd_wav_free(&w);
    /* 24 bits, extensible: 0x123456 and -1 */
    const uint8_t s24[6] = {0x56, 0x34, 0x12, 0xff, 0xff, 0xff};
    n = make_wav(buf, 0xFFFE, 1, 44100, 24, s24, sizeof s24);
    assert_int_equal(hd_wav_parse(buf, n, "b.wav", &w, err), 0);
    assert_int_equal(w.frames, 2);
    assert_int_equal(w.samples[0], 0x12345600);
    assert_int_equal(w.samples[1], -256);
    hd_wav_free(&w);
    /* 32 bits */
    const int32_t s32[2] = {-123456789, 987654321};
    memcpy(data, s32, sizeof s32);
    n = make_wav(buf, 1, 2, 48000, 32, data, sizeof s32);
    assert_int_equal(hd_wav_parse(buf, n, "c.wav", &w, err), 0);
    assert_int_equal(w.samples[0], -123456789);
    assert_int_equal(w.samples[1], 987654321);
    hd_wav_free(&w);
    /* refused, one line naming the file */
    n = make_wav(buf, 3, 2, 48000, 32, data, 8);
    assert_int_equal(hd_wav_parse(buf, n, "f.wav", &w, err), -EINVAL);
    assert_non_null(strstr(err, "f.wav: floating-point"));
    n = make_wav(buf, 1, 2, 48000, 8, data, 8);
    assert_int_equal(hd_wav_parse(buf, n, "g.wav", &w, err), -EINVAL);
    assert_non_null(strstr(err, "only integer PCM"));
    n = make_wav(buf, 1, 2, 48000, 16, data, 0);
    assert_int_equal(hd_wav_parse(buf, n, "h.wav", &w, err), -EINVAL);
    assert_non_null(strstr(err, "no frames"));
    assert_int_equal(hd_wav_parse((const uint8_t *)"RIFX....WAVE", 12, "i.wav", &w, err), -EINVAL);
    assert_non_null(strstr(err, "not a WAV file"));
    n = make_wav(buf, 1, 2, 48000, 16, data, 8);
    assert_int_equal(hd_wav_parse(buf, 30, "j.wav", &w, err), -EINVAL); /* cut inside the fmt chunk */
    assert_null(strchr(err, '\n'));
    assert_null(w.samples);
}

static void wav_files(void **state)
{
    (void)state;
    char path[300], err[HD_ERR_MAX];
    struct hd_wav w;
    /* a FIFO, a directory, a missing file: refused at once, never read */
    snprintf(path, sizeof path, "%s/fifo.wav", dir);
    assert_int_equal(mkfifo(path, 0600), 0);
    assert_int_equal(hd_wav_read(path, &w, err), -EINVAL);
    assert_non_null(strstr(err, "not a regular file (a FIFO"));
    assert_int_equal(hd_wav_read(dir, &w, err), -EINVAL);
    assert_non_null(strstr(err, "directory"));
    snprintf(path, sizeof path, "%s/none.wav", dir);
    assert_int_equal(hd_wav_read(path, &w, err), -ENOENT);
    assert_non_null(strstr(err, "none.wav: cannot open"));
    /* the writer: the temporary file exists while open, is renamed on commit */
    struct hd_wav_out o;
    snprintf(path, sizeof path, "%s/rec.wav", dir);
    assert_int_equal(hd_wav_out_open(&o, path, err), 0);
    assert_int_equal(access(path, F_OK), -1);
    const int32_t s[6] = {1 << 16, -(1 << 16), 32767 << 16, 7, -8, 9};
    assert_int_equal(hd_wav_out_commit(&o, 3, 48000, 32, s, 2, err), 0);
    assert_int_equal(hd_wav_read(path, &w, err), 0);
    assert_int_equal(w.channels, 3);
    assert_int_equal(w.frames, 2);
    assert_memory_equal(w.samples, s, sizeof s);
    hd_wav_free(&w);
    assert_int_equal(hd_wav_out_open(&o, path, err), 0);
    assert_int_equal(hd_wav_out_commit(&o, 3, 48000, 16, s, 2, err), 0);
    assert_int_equal(hd_wav_read(path, &w, err), 0);
    assert_int_equal(w.bits, 16);
    assert_int_equal(w.samples[0], 1 << 16);
    assert_int_equal(w.samples[2], 32767 << 16);
    assert_int_equal(w.samples[3], 0); /* the low half is not kept */
    hd_wav_free(&w);
    /* abort: nothing left, the old recording unchanged */
    assert_int_equal(hd_wav_out_open(&o, path, err), 0);
    hd_wav_out_abort(&o);
    DIR *d = opendir(dir);
    unsigned files = 0;
    for (struct dirent *e; (e = readdir(d));)
        files += e->d_name[0] != '.';
    closedir(d);
    assert_int_equal(files, 2); /* fifo.wav, rec.wav */
    assert_int_equal(hd_wav_read(path, &w, err), 0);
    assert_int_equal(w.bits, 16);
    hd_wav_free(&w);
    /* an unwritable place */
    snprintf(path, sizeof path, "%s/no/such/dir/rec.wav", dir);
    assert_int_equal(hd_wav_out_open(&o, path, err), -ENOENT);
    assert_non_null(strstr(err, "cannot write the recording there"));
    assert_int_equal(hd_wav_out_open(&o, dir, err), -EINVAL);
}

static struct hd_board board(const char *extra)
{
    char text[1024];
    snprintf(text, sizeof text,
             "[alsa]\ndevice = hw:0\nformat = S16_LE\nchannels = 10\nchannel_map = 9,8,7,6,5,4,3,2\n%s", extra);
    struct hd_board b;
    char err[HD_ERR_MAX] = "";
    if (hd_board_parse_string(text, "b.ini", &b, err) != 0)
        fail_msg("%s", err);
    return b;
}

static struct hd_wav plan(unsigned channels, unsigned rate, uint64_t frames)
{
    struct hd_wav w = {.channels = channels, .rate_hz = rate, .bits = 16, .frames = frames};
    w.samples = calloc((size_t)frames * channels, sizeof *w.samples);
    assert_non_null(w.samples);
    return w;
}

static void plan_against_board(void **state)
{
    (void)state;
    char err[HD_ERR_MAX];
    struct hd_board b = board("[mixer]\ngain_limit = 0.5\n");
    struct hd_wav p = plan(8, 48000, 100);
    p.samples[17] = 16383 << 16; /* 0.49999 of full scale */
    assert_int_equal(hd_measure_check_plan(&p, "p.wav", &b, err), 0);
    p.samples[18] = 16385 << 16;
    assert_int_equal(hd_measure_check_plan(&p, "p.wav", &b, err), -EINVAL);
    assert_non_null(strstr(err, "p.wav: peak 0.5000 of full scale above [mixer] gain_limit 0.5000 in b.ini"));
    p.samples[18] = 0;
    p.samples[19] = 5; /* below 16 bits: the S16 device would round it */
    assert_int_equal(hd_measure_check_plan(&p, "p.wav", &b, err), -EINVAL);
    assert_non_null(strstr(err, "frame 2 channel 3"));
    hd_wav_free(&p);
    p = plan(8, 44100, 10);
    assert_int_equal(hd_measure_check_plan(&p, "p.wav", &b, err), -EINVAL);
    assert_non_null(strstr(err, "p.wav: plan at 44100 Hz, the board plays 48000 Hz ([alsa] rate_hz in b.ini)"));
    hd_wav_free(&p);
    p = plan(10, 48000, 10); /* the device's 10 channels, but 8 exciters */
    assert_int_equal(hd_measure_check_plan(&p, "p.wav", &b, err), -EINVAL);
    assert_non_null(strstr(err, "plan of 10 channels, the board drives 8 exciters ([alsa] channel_map in b.ini)"));
    hd_wav_free(&p);
}

/* A steady sine of amplitude A counts on exciter 2 for 2 s: the coil's mean
 * power is A^2 / 2 (V / 32767)^2 / Z, and with tau = 0.2 s the heat is
 * that within e^-10 at the end; the model adds each 64-frame step's energy
 * at its end (conservative: + dt / 2 tau = +0.33 %). Ratings 2 % above and
 * below it. */
static void power_against_ratings(void **state)
{
    (void)state;
    const double A = 20000, V = 10, Z = 8;
    const double p_mean = A * A / 2 * (V / 32767) * (V / 32767) / Z;
    struct hd_wav p = plan(8, 48000, 96000);
    for (uint64_t n = 0; n < p.frames; n++)
        p.samples[n * 8 + 2] = (int32_t)lround(A * sin(2 * M_PI * 1000.0 * (double)n / 48000)) * 65536;
    char extra[256], err[HD_ERR_MAX];
    double heat, rated;
    unsigned hot;
    snprintf(extra, sizeof extra,
             "[exciters]\nrated_power_w = %.9g\nimpedance_ohm = 8\nthermal_tau_s = 0.2\n"
             "[amplifier]\nfull_scale_v = 10\n",
             p_mean * 1.02);
    struct hd_board b = board(extra);
    assert_int_equal(hd_measure_check_power(&p, "p.wav", &b, &heat, &rated, &hot, err), 1);
    assert_int_equal(hot, 2);
    assert_true(heat / p_mean > 1.0 && heat / p_mean < 1.005);
    snprintf(extra, sizeof extra,
             "[exciters]\nrated_power_w = %.9g\nimpedance_ohm = 8\nthermal_tau_s = 0.2\n"
             "[amplifier]\nfull_scale_v = 10\n",
             p_mean * 0.98);
    b = board(extra);
    assert_int_equal(hd_measure_check_power(&p, "p.wav", &b, &heat, &rated, &hot, err), -EINVAL);
    assert_non_null(strstr(err, "p.wav: exciter 2 would heat to"));
    assert_non_null(strstr(err, "([exciters] rated_power_w in b.ini)"));
    assert_null(strchr(err, '\n'));
    b = board("");
    assert_int_equal(hd_measure_check_power(&p, "p.wav", &b, &heat, &rated, &hot, err), 0); /* no ratings */
    hd_wav_free(&p);
}

static void render_through_the_map(void **state)
{
    (void)state;
    struct hd_board b = board("");
    struct hd_wav p = plan(8, 48000, 3);
    for (uint32_t i = 0; i < 24; i++)
        p.samples[i] = (int32_t)(i + 1) * 65536;
    int16_t out[5 * 10];
    hd_measure_render(&p, &b, 2, 0, 5, out); /* plan frame 0 at device frame 2 */
    for (uint32_t n = 0; n < 5; n++)
        for (uint32_t c = 0; c < 10; c++) {
            int want = 0;
            if (n >= 2 && c >= 2) /* exciter k on ALSA channel 9 - k */
                want = (int)((n - 2) * 8 + (9 - c) + 1);
            assert_int_equal(out[n * 10 + c], want);
        }
    b.format = HD_FMT_S32_LE;
    int32_t out32[2 * 10];
    hd_measure_render(&p, &b, 0, 2, 2, out32); /* plan frame 2, then past the end */
    assert_int_equal(out32[9], 17 * 65536);
    assert_int_equal(out32[2], 24 * 65536);
    for (uint32_t c = 0; c < 10; c++)
        assert_int_equal(out32[10 + c], 0);
    hd_wav_free(&p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(wav_reader),
        cmocka_unit_test(wav_files),
        cmocka_unit_test(plan_against_board),
        cmocka_unit_test(power_against_ratings),
        cmocka_unit_test(render_through_the_map),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
