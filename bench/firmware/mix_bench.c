/* Mixing cost per period for 1, 3 and 9 foci (ns per output sample, i.e. per
 * frame x channel), in-process on hapticd's own player. */
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
    char err[HD_ERR_MAX];
    struct hd_program *p;
    if (hd_program_load(path, &b, &p, err)) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    unlink(path);
    printf("period %u frames x %u channels S32_LE, %u-sample signals\n", b.period_frames, b.channels, samples);
    printf("foci  ns/period  ns/sample  gain_us\n");
    const uint32_t K[] = {1, 3, 9};
    for (int i = 0; i < 3; i++) {
        struct hd_player pl;
        hd_player_init(&pl, &b);
        int32_t *out = malloc((size_t)b.period_frames * b.channels * sizeof *out);
        uint32_t ids[9];
        for (uint32_t k = 0; k < K[i]; k++)
            ids[k] = k;
        uint64_t render_ns = 0, gain_ns = 0, periods = 0;
        for (int rep = 0; rep < 20; rep++) {
            uint64_t t0 = hd_now_ns();
            hd_player_start(&pl, p, ids, K[i]); /* gain: O(K^2) Gram + block-peak bound */
            uint64_t t1 = hd_now_ns();
            gain_ns += t1 - t0;
            while (hd_player_active(&pl)) {
                hd_player_render(&pl, out, b.period_frames);
                periods++;
            }
            render_ns += hd_now_ns() - t1;
        }
        double per_period = (double)render_ns / periods;
        printf("%4u  %9.0f  %9.3f  %7.2f\n", K[i], per_period, per_period / (b.period_frames * b.channels),
               gain_ns / 20.0 / 1e3);
        free(out);
        hd_player_free(&pl);
    }
    hd_program_free(p);
    return 0;
}
