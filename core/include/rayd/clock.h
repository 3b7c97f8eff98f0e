/* The one clock of rayd: monotonic milliseconds. Deadlines (job.h), render
 * statistics and the daemon's timeouts all read it, so their figures agree. */
#ifndef RD_CLOCK_H
#define RD_CLOCK_H

/* Milliseconds since an arbitrary fixed point; never goes back. */
double rd_now_ms(void);

#endif
