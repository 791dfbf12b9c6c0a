/* Cost of loading a table (docs/BENCHMARKS.md, "Table reader"): the whole
 * validation, and its parts (CRC-32, the Gram diagonal and the off-diagonal
 * elements against the payload), for K foci of C channels x N frames.
 * Not a test: run it by hand, e.g. `table_check_timing 9 169`. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <zlib.h>

#include "haptic_table_internal.h"

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Best of `reps` timings of fn(ctx): the least disturbed run on a shared machine. */
struct job {
    const uint8_t *b;
    size_t size;
    const int16_t *s;
    uint32_t k;
    uint64_t per_focus;
    int what;
};
static volatile int64_t sink;

static void run(const struct job *j)
{
    if (j->what == 0) {
        haptic_table t;
        if (haptic_table_validate(j->b, j->size, &t, NULL) != 0)
            abort();
    } else if (j->what == 1) {
        sink += (int64_t)crc32(crc32(0L, Z_NULL, 0), j->b, (uInt)(j->size - 4));
    } else if (j->what == 2) {
        for (uint32_t f = 0; f < j->k; f++)
            sink += haptic_table_dot_(j->s + f * j->per_focus, j->s + f * j->per_focus, j->per_focus);
    } else {
        for (uint32_t a = 1; a < j->k; a++)
            for (uint32_t b = 0; b < a; b++)
                sink += haptic_table_dot_(j->s + a * j->per_focus, j->s + b * j->per_focus, j->per_focus);
    }
}

static double best_ms(struct job *j, int reps)
{
    double best = 1e30;
    for (int r = 0; r < reps; r++) {
        double t0 = now_s();
        run(j);
        double dt = now_s() - t0;
        best = dt < best ? dt : best;
    }
    return 1e3 * best;
}

int main(int argc, char **argv)
{
    const uint16_t C = 8;
    const uint32_t N = 2880; /* the Fig. 7 table: 60 ms at 48 kHz */
    printf("channels %u, frames %lu (%.1f ms at 48 kHz); best of 5 runs, ms\n", (unsigned)C, (unsigned long)N,
           N / 48.0);
    printf("%6s %10s %10s %10s %12s %10s\n", "foci", "bytes", "validate", "crc32", "gram diag", "gram off");
    for (int a = 1; a < argc; a++) {
        uint32_t K = (uint32_t)strtoul(argv[a], NULL, 10);
        if (K < 1 || K > HAPTIC_TABLE_MAX_FOCI)
            return 2;
        uint64_t per_focus = (uint64_t)N * C;
        int16_t *s = malloc(sizeof *s * per_focus * K);
        uint32_t *ids = malloc(sizeof *ids * K);
        double *fxy = malloc(sizeof *fxy * 2 * K), *scale = malloc(sizeof *scale * K), *lead = malloc(sizeof *lead * K);
        double cxy[2 * 8];
        uint32_t x = 12345;
        for (uint64_t i = 0; i < per_focus * K; i++) {
            x = x * 1664525u + 1013904223u;
            s[i] = (int16_t)(x >> 16);
        }
        for (uint32_t f = 0; f < K; f++) {
            ids[f] = f + 1;
            fxy[2 * f] = fxy[2 * f + 1] = 0.1;
            scale[f] = 1e-5;
            lead[f] = 0.0572;
        }
        for (int c = 0; c < 2 * C; c++)
            cxy[c] = 0.01 * c;
        haptic_table_spec spec = {48000, C,    K,        N,    cxy,  ids,  fxy,
                                  scale, s,    "timing", NULL, NULL, NULL, HAPTIC_DRIVE_FORCE,
                                  1.0,   lead, NULL,     NULL};
        uint64_t size = haptic_table_encoded_size(&spec);
        uint8_t *b = malloc(size);
        haptic_table_error err;
        if (haptic_table_encode(&spec, b, size, &err) != 0) {
            fprintf(stderr, "%s\n", err.message);
            return 1;
        }
        struct job j = {b, size, s, K, per_focus, 0};
        double ms[4];
        for (j.what = 0; j.what < 4; j.what++)
            ms[j.what] = best_ms(&j, 5);
        printf("%6lu %10llu %10.2f %10.2f %12.2f %10.2f\n", (unsigned long)K, (unsigned long long)size, ms[0], ms[1],
               ms[2], ms[3]);
        free(b);
        free(s);
        free(ids);
        free(fxy);
        free(scale);
        free(lead);
    }
    return 0;
}
