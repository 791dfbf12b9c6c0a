/* rt.h - real-time setup that degrades to a warning when not permitted. */
#ifndef HD_RT_H
#define HD_RT_H

#include <pthread.h>

/* Stack of the daemon's threads: with mlockall(MCL_FUTURE) every stack page is
 * locked, so the 8 MiB default would cost 8 MiB of locked memory per thread. */
#define HD_THREAD_STACK (256u * 1024u)

/* mlockall(MCL_CURRENT | MCL_FUTURE); logs a warning and returns -errno if refused. */
int hd_rt_lock_memory(void);

/* Create a thread at SCHED_FIFO `priority` (0: ordinary scheduling). When the
 * system refuses (no CAP_SYS_NICE / RLIMIT_RTPRIO), log a warning and create
 * it with ordinary scheduling. *is_rt tells which one happened. */
int hd_rt_thread_create(pthread_t *th, int priority, void *(*fn)(void *), void *arg, int *is_rt);

#endif
