/* The daemon's log: one line per event on stderr (or a file that SIGHUP
 * reopens, for logrotate), as text or, with --log-format json, as one JSON
 * object per line: start-up, warnings, shutdown and access lines alike. */
#ifndef RD_LOG_H
#define RD_LOG_H

#include <cJSON.h>

#include "rayd/error.h"

typedef struct rd_log rd_log;

/* path NULL: stderr. The file is opened for appending and put on the
 * process's stderr, so libmicrohttpd's own messages land there too.
 * NULL with *err set when it cannot be opened. Freed by rd_log_free. */
rd_log *rd_log_open(const char *path, int json, rd_error *err);

/* Opens the file again (a rotated log gets a new one); RD_OK on stderr. */
rd_error_code rd_log_reopen(rd_log *log, rd_error *err);

void rd_log_free(rd_log *log);

int rd_log_is_json(const rd_log *log);

/* A message of `level` ("info", "warning", "error"). Text: "rayd serve:
 * MESSAGE"; JSON: {"time", "level", "msg"}. log NULL: text on stderr. */
void rd_log_msg(rd_log *log, const char *level, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* The same with more fields: JSON adds them to the object, text appends
 * them as key=value. Takes ownership of fields (may be NULL). */
void rd_log_event(rd_log *log, const char *level, const char *msg, cJSON *fields);

/* A line written as given (the access log builds its own); one write. */
void rd_log_line(rd_log *log, const char *line);

/* The time now as RFC 3339 UTC with milliseconds, into buf (>= 32 bytes). */
void rd_log_time(char *buf, size_t size);

#endif
