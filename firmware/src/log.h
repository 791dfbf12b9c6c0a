/* log.h - logging to stderr and, when enabled, syslog. Never called from the
 * real-time audio thread: it reports through atomic counters instead.
 *
 * One escaping rule for everything that reaches the log, whatever its
 * origin (a trigger line, a board value, a path, libasound's own words):
 * control bytes, DEL and bytes that are not valid UTF-8 are written as
 * \xNN, and a backslash as \\, so a line in the log is one printable line
 * and nothing sent to the daemon can move a terminal's cursor, set its title
 * or forge a second log line. The rule is text.h's hd_text_escape. */
#ifndef HD_LOG_H
#define HD_LOG_H

#include <stddef.h>
#include <stdint.h>
#include <syslog.h>

void hd_log_use_syslog(int on);
__attribute__((format(printf, 2, 3))) void hd_log(int priority, const char *fmt, ...);

/* A flood guard for warnings caused from outside (bad trigger lines): at
 * most `burst` messages per `window_ns`; the rest are counted and reported
 * in one summary line when the next window opens. */
struct hd_log_limit {
    unsigned burst;
    uint64_t window_ns;
    uint64_t window_start_ns;
    unsigned in_window;
    unsigned long suppressed;
};
/* 1: log this one; 0: suppressed (counted). `what` names the source in the
 * summary ("triggers /run/hapticd.fifo: 2041 bad lines not shown"). */
int hd_log_limit_allow(struct hd_log_limit *l, uint64_t now_ns, const char *what);
/* Logs the summary of what is still suppressed (at shutdown, at EOF). */
void hd_log_limit_flush(struct hd_log_limit *l, const char *what);

#endif
