/* Trigger -> mixed samples handed to ALSA, measured inside hapticd (from the
 * moment the trigger thread has read the command off the FIFO to the return
 * of snd_pcm_writei with the voice's first period), over >= 10^4 triggers
 * sent at random intervals through a FIFO to hapticd on the host-sim board
 * (ALSA file plugin, clock-paced). Also hapticd's resident memory.
 *   hapticd_latency_bench [triggers (10000)] [rt-priority (0)] [period_frames (64)] [rewind (1)] [protect (0)]
 * rewind 0 writes `rewind = false` in the board: triggers start at the next
 * period boundary (the behaviour before rewinding, for comparison).
 * protect 1 adds [exciters] ratings (1000 W into 4 ohm behind a 10 V
 * amplifier: the budget is computed for every voice and every period but
 * never binds), so the two runs compare what protection costs the path. */
#define _GNU_SOURCE
#include "bench_table.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

extern char **environ;

int main(int argc, char **argv)
{
    long triggers = argc > 1 ? atol(argv[1]) : 10000;
    const char *prio = argc > 2 ? argv[2] : "0";
    const char *period = argc > 3 ? argv[3] : "64";
    const int rewind = argc > 4 ? atoi(argv[4]) : 1;
    const int protect = argc > 5 ? atoi(argv[5]) : 0;
    char dir[] = "/tmp/hapticd-lat-XXXXXX";
    if (!mkdtemp(dir))
        return 1;
    char table[128], fifo[128], wav[160], report[128], board[128], device[200];
    snprintf(table, sizeof table, "%s/t.htab", dir);
    snprintf(fifo, sizeof fifo, "%s/fifo", dir);
    snprintf(wav, sizeof wav, "%s/out.wav", dir);
    snprintf(report, sizeof report, "%s/report.txt", dir);
    snprintf(board, sizeof board, "%s/board.ini", dir);
    snprintf(device, sizeof device, "hostsim:FILE=\"%s\"", wav);
    /* 9 foci x 10 ms signals (a short haptic pulse); the host-sim board with the chosen period. */
    if (bench_table_write(table, 9, 480) || mkfifo(fifo, 0600))
        return 1;
    FILE *bf = fopen(board, "w");
    fprintf(bf,
            "[alsa]\ndevice = hostsim\nconfig = %.*s/asoundrc\nperiod_frames = %s\npacing = clock\nrewind = %s\n"
            "[realtime]\nmlock = false\n%s",
            (int)(strrchr(HOSTSIM_BOARD, '/') - HOSTSIM_BOARD), HOSTSIM_BOARD, period, rewind ? "true" : "false",
            protect ? "[exciters]\nrated_power_w = 1000\nimpedance_ohm = 4\n[amplifier]\nfull_scale_v = 10\n" : "");
    fclose(bf);
    char *args[] = {
        "hapticd", "--board",          board,  "--table",       table,        "--triggers", fifo, "--alsa-device",
        device,    "--latency-report", report, "--rt-priority", (char *)prio, NULL};
    pid_t pid;
    if (posix_spawn(&pid, HAPTICD_EXE, NULL, NULL, args, environ))
        return 1;
    int fd = open(fifo, O_WRONLY);
    struct timespec ts = {0, 200000000};
    nanosleep(&ts, NULL);
    uint32_t x = 12345;
    for (long i = 0; i < triggers; i++) {
        char line[32];
        int n = snprintf(line, sizeof line, (i % 7) ? "focus %ld\n" : "foci %ld,%ld\n", i % 9, (i + 4) % 9);
        if (write(fd, line, (size_t)n) != n)
            return 1;
        /* uniform 1..3 ms between touches: uncorrelated with the period grid */
        x = x * 1664525u + 1013904223u;
        ts.tv_sec = 0;
        ts.tv_nsec = 1000000 + (long)(x >> 8) % 2000000;
        nanosleep(&ts, NULL);
    }
    ts.tv_nsec = 100000000;
    nanosleep(&ts, NULL);
    kill(pid, SIGTERM);
    int st;
    waitpid(pid, &st, 0);
    close(fd);
    FILE *f = fopen(report, "r");
    if (!f)
        return 1;
    char buf[256];
    printf("hapticd host-sim, FIFO triggers at random 1-3 ms intervals, period %s frames, rt priority %s, rewind %s, "
           "exciter protection %s\n",
           period, prio, rewind ? "on" : "off", protect ? "on" : "off");
    long rss = 0, hwm = 0, anon = 0, table_bytes = 0;
    while (fgets(buf, sizeof buf, f)) {
        fputs(buf, stdout);
        sscanf(buf, "vm_rss_kib %ld", &rss);
        sscanf(buf, "vm_hwm_kib %ld", &hwm);
        sscanf(buf, "table_bytes %ld", &table_bytes);
        sscanf(buf, "rss_anon_kib %ld", &anon);
    }
    fclose(f);
    /* The daemon's own memory beyond the table: anonymous resident pages minus
     * the table buffer; the rest of VmRSS is shared libraries (libasound, libc). */
    printf("resident_beyond_table_kib %ld (RssAnon %ld KiB - table %ld KiB; VmRSS %ld KiB, VmHWM %ld KiB)\n",
           anon - table_bytes / 1024, anon, table_bytes / 1024, rss, hwm);
    char cmd[200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 && WIFEXITED(st) && WEXITSTATUS(st) == 0 ? 0 : 1;
}
