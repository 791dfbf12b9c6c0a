/* log.h - logging to stderr and, when enabled, syslog. Never called from the
 * real-time audio thread: it reports through atomic counters instead. */
#ifndef HD_LOG_H
#define HD_LOG_H

#include <syslog.h>

void hd_log_use_syslog(int on);
__attribute__((format(printf, 2, 3))) void hd_log(int priority, const char *fmt, ...);

#endif
