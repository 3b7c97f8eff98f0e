/* Turning tokens into typed values with the messages of scene-format.md. */
#ifndef RD_VALUE_PARSE_H
#define RD_VALUE_PARSE_H

#include <stddef.h>

#include "scene_value.h"

/* 0: a finite decimal number; 1: not a number; 2: a number that is not
 * finite (nan, inf, 1e309). Hex floats and words are not numbers. */
int rd_parse_real(const rd_token *t, double *out);

/* 0: an integer in [lo, hi]; 1: not an integer; 2: out of range. */
int rd_parse_int(const rd_token *t, long long lo, long long hi, long long *out);

/* 0: an unsigned 64-bit integer; 1: otherwise. */
int rd_parse_u64(const rd_token *t, unsigned long long *out);

/* How a message names what was found: 'word' for a cfg word or JSON
 * number, the string "..." for a string, true/null/[...]/{...} as such.
 * buf holds at least 200 bytes. */
const char *rd_token_what(const rd_token *t, char *buf, size_t size);

#endif
