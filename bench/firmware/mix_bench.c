/* Mixing cost per period for 1, 3 and 9 foci (ns per output sample, i.e. per
 * frame x channel), in-process on hapticd's own player, with the exciters'
 * protection off and on (ratings that never bind: what computing the heat
 * and the admission costs). Each figure is the fastest of 7 runs: the
 * machine's noise only ever adds.
 *
 * Then a trigger's real-time path, per trigger: hd_player_start and the
 * period that carries the voice's first frames (what the audio thread does
 * between taking a trigger and handing the period to ALSA), in two players,
 * protection off and on, fed the same 20,000 triggers alternately, one or
 * two foci 1-3 periods apart (the periods between rendered, untimed): the
 * p50 and p99 of each, and the p99 of the paired difference. Alternating
 * puts the machine's noise on both alike; the thread's wake-up, the same
 * for both, is not in it (hapticd_latency_bench has it, end to end). */
#define _POSIX_C_SOURCE 200809L
#include "bench_table.h"
#include "engine.h"
#include "player.h"
#include "program.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Exciter ratings that never bind (1000 W into 4 ohm behind 10 V): the
 * protection computes everything, lowers nothing. */
static void never_binding_ratings(struct hd_board *b)
{
    b->exciters.enabled = true;
    b->exciters.power_count = b->exciters.impedance_count = 1;
    b->exciters.rated_power_w[0] = 1000.0;
    b->exciters.impedance_ohm[0] = 4.0;
    b->amp_full_scale_v = 10.0;
}

static int cmp_i64(const void *a, const void *b)
{
    const int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return x < y ? -1 : x > y;
}

static double percentile_us(int64_t *v, size_t n, double q)
{
    qsort(v, n, sizeof *v, cmp_i64);
    return v[(size_t)(q * (double)(n - 1))] / 1e3;
}

#define PATH_TRIGGERS 20000u

/* The trigger path, off (players[0]) and on (players[1]), alternately. */
static int trigger_path(const struct hd_program *p, struct hd_board *b)
{
    struct hd_board on = *b;
    never_binding_ratings(&on);
    struct hd_player pl[2];
    if (hd_player_init(&pl[0], b) || hd_player_init(&pl[1], &on))
        return 1;
    int32_t *out = malloc((size_t)b->period_frames * b->channels * sizeof *out);
    int64_t *t[2] = {malloc(PATH_TRIGGERS * sizeof(int64_t)), malloc(PATH_TRIGGERS * sizeof(int64_t))};
    int64_t *diff = malloc(PATH_TRIGGERS * sizeof(int64_t));
    if (!out || !t[0] || !t[1] || !diff)
        return 1;
    uint32_t x = 12345;
    for (uint32_t i = 0; i < PATH_TRIGGERS; i++) {
        const uint32_t ids[2] = {i % 9, (i + 4) % 9};
        x = x * 1664525u + 1013904223u;
        const unsigned between = 1 + (x >> 8) % 3;
        for (int k = 0; k < 2; k++) {
            const int s = (int)(i % 2) ^ k; /* which side goes first alternates too */
            const uint64_t t0 = hd_now_ns();
            hd_player_start(&pl[s], p, ids, i % 7 ? 1 : 2);
            hd_player_render(&pl[s], out, b->period_frames);
            t[s][i] = (int64_t)(hd_now_ns() - t0);
            for (unsigned r = 0; r < between; r++)
                hd_player_render(&pl[s], out, b->period_frames);
        }
        diff[i] = t[1][i] - t[0][i];
    }
    const double d99 = percentile_us(diff, PATH_TRIGGERS, 0.99), d50 = percentile_us(diff, PATH_TRIGGERS, 0.5);
    const double off50 = percentile_us(t[0], PATH_TRIGGERS, 0.5), off99 = percentile_us(t[0], PATH_TRIGGERS, 0.99);
    const double on50 = percentile_us(t[1], PATH_TRIGGERS, 0.5), on99 = percentile_us(t[1], PATH_TRIGGERS, 0.99);
    printf("trigger path (start + first period), %u triggers alternately: protection off p50 %.2f us p99 %.2f us; "
           "on p50 %.2f us p99 %.2f us; on - off per trigger: p50 %+.2f us, p99 %+.2f us\n",
           PATH_TRIGGERS, off50, off99, on50, on99, d50, d99);
    free(out);
    free(t[0]);
    free(t[1]);
    free(diff);
    hd_player_free(&pl[0]);
    hd_player_free(&pl[1]);
    return 0;
}

int main(void)
{
    char path[] = "/tmp/hapticd-mix-bench-XXXXXX";
    int fd = mkstemp(path);
    if (fd < 0)
        return 1;
    close(fd);
    const uint32_t samples = 48000; /* 1 s signals: the loop streams from memory as on the device */
    if (bench_table_write(path, 9, samples))
        return 1;
    struct hd_board b;
    hd_board_defaults(&b);
    strcpy(b.path, "bench");
    strcpy(b.alsa_device, "bench");
    b.max_foci = 9; /* every focus asked plays: the cost of 9 */
    char err[HD_ERR_MAX];
    struct hd_program *p;
    if (hd_program_load(path, &b, &p, err)) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    unlink(path);
    printf("period %u frames x %u channels S32_LE, %u-sample signals\n", b.period_frames, b.channels, samples);
    printf("foci  protect  ns/period  ns/sample  start_us\n");
    const uint32_t K[] = {1, 3, 9};
    for (int protect = 0; protect < 2; protect++) {
        if (protect)
            never_binding_ratings(&b);
        for (int i = 0; i < 3; i++) {
            double best_period = 1e300, best_start = 1e300;
            for (int run = 0; run < 7; run++) {
                struct hd_player pl;
                if (hd_player_init(&pl, &b))
                    return 1;
                int32_t *out = malloc((size_t)b.period_frames * b.channels * sizeof *out);
                uint32_t ids[9];
                for (uint32_t k = 0; k < K[i]; k++)
                    ids[k] = k;
                uint64_t render_ns = 0, start_ns = 0, periods = 0;
                for (int rep = 0; rep < 20; rep++) {
                    uint64_t t0 = hd_now_ns();
                    hd_player_start(&pl, p, ids, K[i]); /* gain: O(K^2) Gram + block-peak bound (+ admission) */
                    uint64_t t1 = hd_now_ns();
                    start_ns += t1 - t0;
                    while (hd_player_active(&pl)) {
                        hd_player_render(&pl, out, b.period_frames);
                        periods++;
                    }
                    render_ns += hd_now_ns() - t1;
                }
                const double per_period = (double)render_ns / periods, start = start_ns / 20.0 / 1e3;
                if (per_period < best_period)
                    best_period = per_period;
                if (start < best_start)
                    best_start = start;
                free(out);
                hd_player_free(&pl);
            }
            printf("%4u  %7s  %9.0f  %9.3f  %8.2f\n", K[i], protect ? "on" : "off", best_period,
                   best_period / (b.period_frames * b.channels), best_start);
        }
    }
    b.exciters.enabled = false; /* trigger_path sets them on one side */
    b.amp_full_scale_v = 0.0;
    const int rc = trigger_path(p, &b);
    hd_program_free(p);
    return rc;
}
