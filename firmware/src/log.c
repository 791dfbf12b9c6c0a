#define _POSIX_C_SOURCE 200809L
#include "log.h"

#include <stdarg.h>
#include <stdio.h>

static int use_syslog;

void hd_log_use_syslog(int on)
{
    use_syslog = on;
    if (on)
        openlog("hapticd", LOG_PID, LOG_DAEMON);
}

void hd_log(int priority, const char *fmt, ...)
{
    char line[1600];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    const char *level = priority <= LOG_ERR ? "error: " : priority == LOG_WARNING ? "warning: " : "";
    fprintf(stderr, "hapticd: %s%s\n", level, line);
    if (use_syslog)
        syslog(priority, "%s", line);
}
