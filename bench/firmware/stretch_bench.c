/* What the speed compensation costs off the real-time path: loading a table
 * (read, validate, envelope) against stretching it (soxr per drive, the
 * exact Gram matrix, the envelope again), for the Fig. 7 table's shape
 * (9 foci x 2770 frames x 8), a dense one (169 foci) and 1 s drives. */
#define _POSIX_C_SOURCE 200809L
#include "bench_table.h"
#include "engine.h"
#include "program.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int main(void)
{
    struct hd_board b;
    hd_board_defaults(&b);
    strcpy(b.path, "bench");
    strcpy(b.alsa_device, "bench");
    const uint32_t shapes[][2] = {{9, 2770}, {169, 2770}, {9, 48000}};
    printf("foci  frames  load_ms  stretch_ms  (ratio 0.98, best of 5)\n");
    for (int i = 0; i < 3; i++) {
        char path[] = "/tmp/hapticd-stretch-bench-XXXXXX";
        int fd = mkstemp(path);
        if (fd < 0 || bench_table_write(path, shapes[i][0], shapes[i][1]))
            return 1;
        close(fd);
        double load = 1e30, stretch = 1e30;
        for (int rep = 0; rep < 5; rep++) {
            char err[HD_ERR_MAX];
            struct hd_program *p;
            uint64_t t0 = hd_now_ns();
            if (hd_program_load(path, &b, &p, err)) {
                fprintf(stderr, "%s\n", err);
                return 1;
            }
            uint64_t t1 = hd_now_ns();
            if (hd_program_set_speed(p, 0.98, err)) {
                fprintf(stderr, "%s\n", err);
                return 1;
            }
            uint64_t t2 = hd_now_ns();
            load = load < (t1 - t0) / 1e6 ? load : (t1 - t0) / 1e6;
            stretch = stretch < (t2 - t1) / 1e6 ? stretch : (t2 - t1) / 1e6;
            hd_program_free(p);
        }
        unlink(path);
        printf("%4u  %6u  %7.2f  %10.2f\n", shapes[i][0], shapes[i][1], load, stretch);
    }
    return 0;
}
