/* table_policy.c - which table plays (see table_policy.h). */
#define _POSIX_C_SOURCE 200809L
#include "table_policy.h"

#include "log.h"
#include "panel.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

/* Stretches p for the panel at temperature `celsius` (NAN: none read): the
 * board's speed ratio and the temperature through the table's panel section
 * (panel.h). */
static int stretch_for_panel(const struct hd_table_policy *tp, struct hd_program *p, double celsius,
                             char err[HD_ERR_MAX])
{
    double ratio;
    int rc;
    if ((rc = hd_panel_speed_ratio(&tp->board->panel, &p->table, celsius, &ratio, err)) != 0 ||
        (rc = hd_program_set_speed(p, ratio, err)) != 0)
        return rc;
    if (ratio == 1.0)
        return 0;
    char at[48] = "";
    if (!isnan(celsius))
        snprintf(at, sizeof at, ", panel at %.2f C", celsius);
    hd_log(LOG_INFO, "panel: drives played %.5f times as fast as stored (board speed ratio %.5f%s), %u frames each%s",
           ratio, tp->board->panel.speed_ratio, at, p->samples, p->stretch_clipped ? ", some samples saturated" : "");
    return 0;
}

/* The table file, stretched for the panel at `celsius`. */
static int load_program(const struct hd_table_policy *tp, double celsius, struct hd_program **out, char err[HD_ERR_MAX])
{
    struct hd_program *p;
    int rc = hd_program_load(tp->path, tp->board, &p, err);
    if (rc)
        return rc;
    if ((rc = stretch_for_panel(tp, p, celsius, err)) != 0) {
        hd_program_free(p);
        return rc;
    }
    *out = p;
    return 0;
}

/* Hands p (owned from here) to the audio thread, stretched for `celsius`. */
static int hand_over(struct hd_table_policy *tp, struct hd_program *p, double celsius, const char *what)
{
    /* The audio thread takes a new table only after the one before the current
     * is retired; wait for that (a signal length at most). */
    int rc = hd_engine_offer(tp->engine, p);
    for (int i = 0; i < 500 && rc == -EBUSY; i++) {
        struct timespec ts = {0, 10000000};
        nanosleep(&ts, NULL);
        hd_engine_collect(tp->engine);
        rc = hd_engine_offer(tp->engine, p);
    }
    if (rc != 0) {
        hd_log(LOG_ERR, "%s refused: the previous hand-over is still being taken over", what);
        hd_program_free(p);
        return -EBUSY;
    }
    tp->latest = p; /* alive until a later one is handed over and this one retired (freed by the collect) */
    tp->celsius = celsius;
    tp->refused_celsius = NAN;
    hd_log(LOG_INFO, "%s %s (%u foci, %u channels, %u samples)", what, tp->path, p->focus_count, p->channel_count,
           p->samples);
    if (tp->handed_over)
        tp->handed_over(tp->ctx, p);
    return 0;
}

int hd_table_policy_log_range(const struct hd_table_policy *tp, double level)
{
    char note[HD_ERR_MAX];
    const int moved = tp->latest ? hd_program_range_note(tp->latest, level, note, sizeof note) : 0;
    if (moved > 0)
        hd_log(LOG_INFO, "%s", note);
    return moved;
}

int hd_table_policy_open(struct hd_table_policy *tp, const struct hd_board *b, const char *path, double now_s,
                         struct hd_program **first, char err[HD_ERR_MAX])
{
    memset(tp, 0, sizeof *tp);
    tp->board = b;
    tp->path = path;
    tp->celsius = tp->refused_celsius = NAN;
    const struct hd_panel_board *pb = &b->panel;
    if (pb->temperature_input[0]) {
        /* A sensor whose driver probes late is not fatal: the table plays at
         * the board's speed ratio until the temperature can be read. */
        if (hd_panel_read_celsius(pb->temperature_input, &tp->celsius, err) != 0) {
            hd_log(LOG_WARNING,
                   "[panel] temperature_input: %s: the table plays at the board's speed ratio until it "
                   "can be read",
                   err);
            tp->celsius = NAN;
            tp->sensor_failing = true;
        }
        tp->next_poll_s = now_s + pb->temperature_poll_s;
    }
    int rc = load_program(tp, tp->celsius, first, err);
    if (rc == 0)
        tp->latest = *first;
    return rc;
}

void hd_table_policy_attach(struct hd_table_policy *tp, struct hd_engine *e,
                            void (*handed_over)(void *ctx, const struct hd_program *p), void *ctx)
{
    tp->engine = e;
    tp->handed_over = handed_over;
    tp->ctx = ctx;
}

int hd_table_policy_reload(struct hd_table_policy *tp)
{
    struct hd_program *p;
    char err[HD_ERR_MAX];
    hd_engine_collect(tp->engine);
    int rc = load_program(tp, tp->celsius, &p, err);
    if (rc != 0) {
        hd_log(LOG_ERR, "reload refused, the current table keeps playing: %s", err);
        return rc;
    }
    /* A new file may bring other ranges; a re-stretch keeps them, so it does not say them again. */
    if ((rc = hand_over(tp, p, tp->celsius, "reloaded")) == 0)
        hd_table_policy_log_range(tp, hd_player_level(&tp->engine->player));
    return rc;
}

/* A temperature step: the table playing now (not the file, which SIGHUP
 * reloads), stretched for `celsius`. A temperature it cannot be stretched
 * for is logged once and not tried again until the panel moves a step on. */
static int restretch(struct hd_table_policy *tp, double celsius)
{
    struct hd_program *p;
    char err[HD_ERR_MAX];
    hd_engine_collect(tp->engine);
    int rc = hd_program_clone(tp->latest, tp->board, &p, err);
    if (rc == 0 && (rc = stretch_for_panel(tp, p, celsius, err)) != 0)
        hd_program_free(p);
    if (rc != 0) {
        hd_log(LOG_ERR, "panel at %.2f C: the table keeps playing as it is: %s", celsius, err);
        tp->refused_celsius = celsius;
        return rc;
    }
    return hand_over(tp, p, celsius, "re-stretched");
}

int hd_table_policy_poll(struct hd_table_policy *tp, double now_s)
{
    const struct hd_panel_board *pb = &tp->board->panel;
    if (!pb->temperature_input[0] || now_s < tp->next_poll_s)
        return 0;
    tp->next_poll_s = now_s + pb->temperature_poll_s;
    double t;
    char err[HD_ERR_MAX];
    if (hd_panel_read_celsius(pb->temperature_input, &t, err) != 0) {
        if (!tp->sensor_failing)
            hd_log(LOG_WARNING, "panel temperature unreadable, the table keeps playing as it is: %s", err);
        tp->sensor_failing = true;
        return 0;
    }
    if (tp->sensor_failing)
        hd_log(LOG_INFO, "panel temperature readable again: %.2f C", t);
    tp->sensor_failing = false;
    if (fabs(t - tp->celsius) < pb->temperature_step_k ||
        (!isnan(tp->refused_celsius) && fabs(t - tp->refused_celsius) < pb->temperature_step_k))
        return 0;
    if (isnan(tp->celsius))
        hd_log(LOG_INFO, "panel temperature %.2f C: stretching the table for it", t);
    else
        hd_log(LOG_INFO, "panel temperature %.2f C (the table is stretched for %.2f C): stretching again", t,
               tp->celsius);
    int rc = restretch(tp, t);
    return rc == 0 ? 1 : rc;
}
