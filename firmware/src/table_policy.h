/* table_policy.h - which table plays, decided on the main thread, off the
 * real-time path: the table file stretched for the panel (panel.h).
 *
 *   start        the file, stretched for the temperature read then (a sensor
 *                that cannot be read yet is not fatal: the board's speed
 *                ratio alone until it can be read);
 *   SIGHUP       the file again, stretched for the current temperature; a
 *                file that cannot be loaded or stretched is refused and the
 *                table playing keeps playing;
 *   every temperature_poll_s
 *                the sensor read; once the panel is temperature_step_k or
 *                more from the temperature the table is stretched for (or is
 *                read for the first time), the table that plays (not the
 *                file, which SIGHUP reloads) stretched again. A temperature
 *                it cannot be stretched for is refused once and not tried
 *                again until the panel is a step away from it; a sensor that
 *                cannot be read is logged once per failing stretch and leaves
 *                the table as it is.
 *
 * Each new table goes to the audio thread through hd_engine_offer (waiting,
 * a signal length at most, for the one before to be taken over), then to the
 * `handed_over` hook: what else follows the table (the daemon's touchscreen
 * foci and touch -> focal peak chain). After a reload, what the new
 * table's safe ranges (format 1.3) do at the user's current level is logged
 * in one line (a re-stretch keeps the ranges: not said again). */
#ifndef HD_TABLE_POLICY_H
#define HD_TABLE_POLICY_H

#include "board.h"
#include "engine.h"
#include "hd_defs.h"
#include "program.h"

#include <stdbool.h>

struct hd_table_policy {
    const struct hd_board *board;
    const char *path;         /* the table file */
    struct hd_engine *engine; /* the engine the tables are handed to (hd_table_policy_attach) */
    void (*handed_over)(void *ctx, const struct hd_program *p);
    void *ctx;
    double celsius;            /* panel temperature the current table is stretched for; NAN: none read */
    double refused_celsius;    /* a temperature the table could not be stretched for; NAN: none */
    double next_poll_s;        /* when the sensor is read next, on the caller's clock */
    bool sensor_failing;       /* the last reading failed (logged once per failing stretch) */
    struct hd_program *latest; /* handed over last: what a temperature step stretches again */
};

/* The first table: reads the board's temperature sensor, if it has one (the
 * next reading is due temperature_poll_s after now_s), and loads the file at
 * `path` stretched for it. 0 with *first, for hd_engine_init (which owns it
 * from then on); or -errno with a one-line message in err. */
int hd_table_policy_open(struct hd_table_policy *tp, const struct hd_board *b, const char *path, double now_s,
                         struct hd_program **first, char err[HD_ERR_MAX]);

/* The engine now playing the first table, and the hook called after every
 * later hand-over (NULL: none). Before the first reload or poll. */
void hd_table_policy_attach(struct hd_table_policy *tp, struct hd_engine *e,
                            void (*handed_over)(void *ctx, const struct hd_program *p), void *ctx);

/* Logs what the clamp into the safe ranges of the latest table does at
 * `level` (hd_program_range_note), nothing when it does nothing. Returns
 * the number of foci it moves. */
int hd_table_policy_log_range(const struct hd_table_policy *tp, double level);

/* SIGHUP. 0: the file, stretched for the current temperature, was handed
 * over; otherwise refused (logged), the current table keeps playing. */
int hd_table_policy_reload(struct hd_table_policy *tp);

/* Each turn of the main loop, now_s on the clock of hd_table_policy_open.
 * 1: a table stretched for a new temperature was handed over; 0: nothing to
 * do (not due, no sensor, no step, a refused temperature, a sensor that
 * cannot be read); negative: a temperature refused now (logged). */
int hd_table_policy_poll(struct hd_table_policy *tp, double now_s);

#endif
