/* Running the real hapticd on the host-sim board (ALSA "file" plugin) for
 * the integration suites: a scratch folder, the process, its board, its
 * stderr and the WAV it plays into. */
#ifndef HOSTSIM_RUN_H
#define HOSTSIM_RUN_H

#include <sndfile.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#define HS_CHANNELS 8u

extern char hs_dir[256]; /* the scratch folder of the suite (hs_setup / hs_teardown) */

int hs_setup(void **state);
int hs_teardown(void **state);
/* hs_dir/name */
void hs_path(char *out, size_t cap, const char *name);
/* The files of one hapticd run in hs_dir: STEM.htab, STEM-triggers (a
 * FIFO's path), STEM.wav, STEM.ini, STEM-stderr.txt, STEM-report.txt,
 * STEM-script.txt, and the host-sim PCM that writes STEM.wav. */
struct hs_files {
    char table[300], fifo[300], wav[300], board[300], err[300], report[300], script[300], device[400];
};
void hs_files(struct hs_files *f, const char *stem);
/* hapticd with argv, its stderr into stderr_path. */
pid_t hs_spawn(char *const argv[], const char *stderr_path);
/* hapticd live on f's board and table with triggers from f's FIFO (made
 * anew) and the host-sim device, with f's latency report when `report`;
 * returns once it runs, the FIFO open for writing in *fd. */
pid_t hs_start_live(const struct hs_files *f, int report, int *fd);
int hs_wait_exit(pid_t pid);
/* A live run must end with status 0; otherwise fails with what hapticd said. */
void hs_assert_clean_exit(pid_t pid, const char *stderr_path);
/* The host-sim board with a test format and map; `alsa_extra` lines follow
 * the [alsa] keys (further sections may follow them too). */
void hs_write_board_extra(const char *file, const char *format, const char *map, const char *alsa_extra);
void hs_write_board(const char *file, const char *format, const char *map);
/* The WAV's frames (8 channels, 48 kHz, of `want_format`), as int. */
int32_t *hs_read_wav(const char *file, sf_count_t *frames, int want_format);
int hs_file_contains(const char *file, const char *needle);
/* Waits up to 5 s for `needle` in the file. */
void hs_wait_for(const char *file, const char *needle);
void hs_sleep_ms(long ms);
/* Writes "focus ID" to a trigger FIFO. */
void hs_send_focus(int fd, uint32_t id);
/* The first frame from `from` with a non-zero sample, or -1. */
sf_count_t hs_onset(const int32_t *w, sf_count_t frames, sf_count_t from);
/* The number after "key " in a latency report, or -1. */
long hs_report_value(const char *file, const char *key);

#endif
