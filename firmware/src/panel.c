/* panel.c - temperature input and the speed ratio (panel.h). */
#define _POSIX_C_SOURCE 200809L
#include "panel.h"

#include <haptic_file.h>
#include <haptic_stretch.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int hd_panel_read_celsius(const char *path, double *celsius, char err[HD_ERR_MAX])
{
    /* Non-blocking and a regular file (sysfs attributes are): a FIFO at the
     * path would block the main thread, and with it the signals, forever.
     * No bound on the size: a sysfs attribute says 4096, and only the
     * first bytes are read. */
    int fd;
    haptic_file_status fs;
    const int orc = haptic_file_open_regular(path, HAPTIC_FILE_NO_LIMIT, &fd, &fs);
    if (fs.refusal == HAPTIC_FILE_CANNOT_OPEN)
        snprintf(err, HD_ERR_MAX, "%s: %s", path, strerror(fs.error));
    else if (orc)
        snprintf(err, HD_ERR_MAX, "%s: not a regular file (a temperature input is a sysfs attribute)", path);
    if (orc)
        return orc;
    char buf[32];
    ssize_t n = read(fd, buf, sizeof buf - 1);
    int e = errno;
    close(fd);
    if (n < 0) {
        snprintf(err, HD_ERR_MAX, "%s: %s", path, strerror(e));
        return -e;
    }
    buf[n] = '\0';
    char *end;
    errno = 0;
    long long m = strtoll(buf, &end, 10);
    if (end == buf || errno || (*end && strcmp(end, "\n") != 0) || m < -273150 || m > 1000000) {
        snprintf(err, HD_ERR_MAX, "%s: '%.*s' is not a temperature in millidegrees Celsius", path,
                 (int)strcspn(buf, "\n"), buf);
        return -EINVAL;
    }
    *celsius = (double)m / 1000.0;
    return 0;
}

int hd_panel_speed_ratio(const struct hd_panel_board *pb, const haptic_table *t, double celsius, double *ratio,
                         char err[HD_ERR_MAX])
{
    double alpha = pb->speed_ratio;
    haptic_panel panel;
    const int known = haptic_table_panel(t, &panel) == 0;
    if ((pb->temperature_input[0] || !isnan(celsius)) && !known) {
        snprintf(err, HD_ERR_MAX,
                 "[panel] temperature_input: the table has no panel section (format 1.2 from "
                 "calibgen): its calibration temperature and dE/E/dT are unknown");
        return -EINVAL;
    }
    if (!isnan(celsius)) {
        const double e = 1.0 + panel.youngs_per_k * (celsius - panel.temperature_c);
        alpha *= e > 0 ? sqrt(e) : NAN;
    }
    if (!(alpha >= HAPTIC_STRETCH_MIN_RATIO && alpha <= HAPTIC_STRETCH_MAX_RATIO)) {
        snprintf(err, HD_ERR_MAX, "panel speed ratio %.4g at %.2f C is outside %g..%g: the table does not hold there",
                 alpha, celsius, HAPTIC_STRETCH_MIN_RATIO, HAPTIC_STRETCH_MAX_RATIO);
        return -EINVAL;
    }
    *ratio = alpha;
    return 0;
}
