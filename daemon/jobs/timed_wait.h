/* Waiting on a condition variable for at most a number of milliseconds
 * (pthread_cond_timedwait takes an absolute CLOCK_REALTIME time). */
#ifndef RD_TIMED_WAIT_H
#define RD_TIMED_WAIT_H

#include <pthread.h>

/* Waits on cv (mu locked by the caller) until signalled or ms pass. */
void rd_timed_wait(pthread_cond_t *cv, pthread_mutex_t *mu, double ms);

#endif
