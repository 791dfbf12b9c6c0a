/* Mixing cost per period for 1, 3 and 9 foci (ns per output sample, i.e. per
 * frame x channel), in-process on hapticd's own player, with the exciters'
 * protection off and on (ratings that never bind: what computing the heat
 * and the admission costs). Each figure is the fastest of 7 runs: the
 * machine's noise only ever adds. */
#define _POSIX_C_SOURCE 200809L
#include "bench_table.h"
#include "engine.h"
#include "player.h"
#include "program.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

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
        if (protect) {
            b.exciters.enabled = true;
            b.exciters.power_count = b.exciters.impedance_count = 1;
            b.exciters.rated_power_w[0] = 1000.0;
            b.exciters.impedance_ohm[0] = 4.0;
            b.amp_full_scale_v = 10.0;
        }
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
    hd_program_free(p);
    return 0;
}
