/* The clocks of rayd: monotonic milliseconds, which deadlines (job.h),
 * render statistics and the daemon's timeouts all read, so their figures
 * agree; and the wall clock, for what is stamped and kept (records, the
 * store's jobs). */
#ifndef RD_CLOCK_H
#define RD_CLOCK_H

/* Milliseconds since an arbitrary fixed point; never goes back. */
double rd_now_ms(void);

/* Milliseconds since the Unix epoch (CLOCK_REALTIME): may jump. */
long long rd_wall_ms(void);

#endif
