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
/* The same with its stdout into stdout_path (NULL: inherited). */
pid_t hs_spawn_out(char *const argv[], const char *stdout_path, const char *stderr_path);
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
/* The whole file, NUL-terminated, its length in *len (fails when it cannot
 * be read). Free with free(). */
char *hs_slurp(const char *file, size_t *len);
/* How many times `needle` occurs in `text`. */
unsigned hs_count(const char *text, const char *needle);
/* The same in the whole file (0 when there is no such file yet). */
unsigned hs_file_count(const char *file, const char *needle);
/* Whether the file (all of it) holds `needle`. */
int hs_file_contains(const char *file, const char *needle);
/* Waits (10 s at most, then fails) until `needle` is in the file... */
void hs_wait_for(const char *file, const char *needle);
/* ...or is there `k` times. */
void hs_wait_count(const char *file, const char *needle, unsigned k);
void hs_sleep_ms(long ms);
/* Writes "focus ID" to a trigger FIFO. */
void hs_send_focus(int fd, uint32_t id);
/* Waits (10 s at most) until hapticd has read every byte written to the
 * trigger FIFO whose write end is fd. */
void hs_wait_fifo_read(int fd);

/* The WAV hapticd is writing (8 channels, S32_LE; the file plugin appends
 * and fixes the header up on close), as far as it is on disk: its whole
 * frames, as int, or NULL (*frames 0) when no frame is there yet. */
int32_t *hs_wav_snapshot(const char *file, sf_count_t *frames);
/* A voice in such a WAV: `frames` frames of `samples` (8 channels, at the
 * table's scale: x 65536 in the WAV) from frame `at`. */
struct hs_voice {
    sf_count_t at;
    const int16_t *samples;
    uint32_t frames;
};
/* Waits (10 s at most) until the WAV holds, at or after frame `from`, a
 * frame that the `known` voices do not explain, and `length` frames from it
 * on: returns that frame, where a new voice starts. What hapticd has written
 * is final (the file plugin rewinds only what it has not written yet), so a
 * voice found here started; one found with its length has been played. */
sf_count_t hs_wait_voice(const char *file, sf_count_t from, sf_count_t length, const struct hs_voice *known,
                         size_t n_known);
/* The first frame from `from` with a non-zero sample, or -1. */
sf_count_t hs_onset(const int32_t *w, sf_count_t frames, sf_count_t from);
/* The number after "key " in a latency report, or -1. */
long hs_report_value(const char *file, const char *key);

#endif
