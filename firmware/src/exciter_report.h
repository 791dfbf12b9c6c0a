/* exciter_report.h - what each focus of a table costs the exciters of a
 * board, before it plays (hapticd --check TABLE --board BOARD): per focus,
 * on its busiest exciter, the energy of one touch, the heat it adds and how
 * many touches a second the rating sustains, at the table's level and at
 * the top of the focus's safe range (format 1.3). The rule is protect.h's
 * (hd_protect_voice_cost), the one hapticd enforces on every voice. */
#ifndef HD_EXCITER_REPORT_H
#define HD_EXCITER_REPORT_H

#include "board.h"
#include "program.h"

#include <stdio.h>

/* Prints the report for program p (loaded against board b, so its rate and
 * channels match). 0; or -EINVAL with a one-line reason in err when the
 * board has no [exciters] ratings or they are out of range. */
int hd_exciter_report(const struct hd_program *p, const struct hd_board *b, const char *board_path, FILE *out,
                      char err[HD_ERR_MAX]);

#endif
