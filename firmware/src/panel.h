/* panel.h - the panel a table plays on, against the plate it was calibrated
 * for: the speed compensation (common/haptic_stretch.h, docs/firmware.md
 * "[panel]").
 *
 * A panel whose response runs alpha times as fast as the calibrated plate's
 * (every resonance alpha times the calibrated one's: the speed ratio,
 * docs/glossary.md; its bending waves run sqrt(alpha) times as fast at one
 * frequency) gets the table's drives alpha times faster: the same focus, the
 * same contrast. alpha = speed_ratio * sqrt(1 + k (T - T0)): the board's
 * speed ratio (the panel's own, measured at the calibration temperature),
 * then Young's modulus moved by the temperature T read from a sensor, with
 * the calibration temperature T0 and dE/E/dT = k from the table's panel
 * section. Everything here runs outside the real-time path. */
#ifndef HD_PANEL_H
#define HD_PANEL_H

#include "board.h"
#include "hd_defs.h"

#include <haptic_table.h>

/* Reads a temperature file as the kernel's hwmon and thermal sysfs files
 * give it: an integer in millidegrees Celsius, optionally followed by a
 * newline. 0, or -errno with "PATH: what" in err. */
int hd_panel_read_celsius(const char *path, double *celsius, char err[HD_ERR_MAX]);

/* alpha for this board and table at temperature `celsius` (NAN: none read,
 * the board's speed ratio alone). -EINVAL with a one-line message when the
 * table has no panel section and the board has a sensor (or a temperature
 * is given), or alpha falls outside what a drive is stretched by
 * (HAPTIC_STRETCH_MIN_RATIO..MAX_RATIO). */
int hd_panel_speed_ratio(const struct hd_panel_board *pb, const haptic_table *t, double celsius, double *ratio,
                         char err[HD_ERR_MAX]);

#endif
