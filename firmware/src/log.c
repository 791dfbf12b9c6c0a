#define _POSIX_C_SOURCE 200809L
#include "log.h"

#include "text.h"

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
    char raw[1600], line[1600];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(raw, sizeof raw, fmt, ap);
    va_end(ap);
    size_t len = n < 0 ? 0 : (size_t)n < sizeof raw ? (size_t)n : sizeof raw - 1;
    hd_text_escape(line, sizeof line, raw, len);
    const char *level = priority <= LOG_ERR ? "error: " : priority == LOG_WARNING ? "warning: " : "";
    fprintf(stderr, "hapticd: %s%s\n", level, line);
    if (use_syslog)
        syslog(priority, "%s", line);
}

int hd_log_limit_allow(struct hd_log_limit *l, uint64_t now_ns, const char *what)
{
    if (now_ns - l->window_start_ns >= l->window_ns || now_ns < l->window_start_ns) {
        hd_log_limit_flush(l, what);
        l->window_start_ns = now_ns;
        l->in_window = 0;
    }
    if (l->in_window < l->burst) {
        l->in_window++;
        return 1;
    }
    l->suppressed++;
    return 0;
}

void hd_log_limit_flush(struct hd_log_limit *l, const char *what)
{
    if (l->suppressed)
        hd_log(LOG_WARNING, "%s: %lu more bad lines not shown (at most %u warnings per %.3g s)", what, l->suppressed,
               l->burst, (double)l->window_ns * 1e-9);
    l->suppressed = 0;
}
