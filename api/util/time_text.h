/* Times as text: RFC 3339 in UTC, the one form rayd writes and reads
 * (records, tables, the .grade file's schedule, query parameters), so that
 * no local time zone ever enters a record. */
#ifndef RD_TIME_TEXT_H
#define RD_TIME_TEXT_H

#include <stddef.h>

/* ms (Unix milliseconds) as 2024-05-01T09:30:00.123Z into buf (>= 32
 * bytes); "" when the time cannot be written. */
void rd_time_text(long long ms, char *buf, size_t size);

/* A UTC time as Unix milliseconds: 2026-12-01 (its midnight),
 * 2026-12-01T09:30 or 2026-12-01T09:30:00, each optionally followed by
 * .mmm and by Z. -1 when text is none of these or before 1970. Offsets
 * other than Z are refused: a schedule means one instant everywhere. */
long long rd_time_parse(const char *text);

#endif
