#define _GNU_SOURCE
#include "rt.h"

#include "log.h"

#include <errno.h>
#include <sched.h>
#include <string.h>
#include <sys/mman.h>

int hd_rt_lock_memory(void)
{
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
        int e = errno;
        hd_log(LOG_WARNING, "mlockall refused (%s): pages may fault on the audio path; raise LimitMEMLOCK",
               strerror(e));
        return -e;
    }
    return 0;
}

int hd_rt_thread_create(pthread_t *th, int priority, void *(*fn)(void *), void *arg, int *is_rt)
{
    *is_rt = 0;
    if (priority > 0) {
        pthread_attr_t attr;
        struct sched_param sp = {.sched_priority = priority};
        pthread_attr_init(&attr);
        pthread_attr_setstacksize(&attr, HD_THREAD_STACK);
        pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
        pthread_attr_setschedpolicy(&attr, SCHED_FIFO);
        pthread_attr_setschedparam(&attr, &sp);
        int rc = pthread_create(th, &attr, fn, arg);
        pthread_attr_destroy(&attr);
        if (rc == 0) {
            *is_rt = 1;
            return 0;
        }
        hd_log(LOG_WARNING, "SCHED_FIFO priority %d refused (%s): audio runs at normal priority; raise LimitRTPRIO",
               priority, strerror(rc));
    }
    pthread_attr_t attr;
    pthread_attr_init(&attr);
    pthread_attr_setstacksize(&attr, HD_THREAD_STACK);
    int rc = pthread_create(th, &attr, fn, arg);
    pthread_attr_destroy(&attr);
    return -rc;
}
