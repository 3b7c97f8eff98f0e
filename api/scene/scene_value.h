/* A key's value as either reader sees it, before the key table gives it a
 * type: a list of tokens with their source text and position. cfg makes
 * one token per white-space separated word; JSON one per number, string or
 * array element. */
#ifndef RD_SCENE_VALUE_H
#define RD_SCENE_VALUE_H

#include <stddef.h>

#define RD_VALUE_MAX_TOKENS 8

typedef struct {
    const char *text; /* not NUL-terminated; points into the reader's buffer */
    size_t len;
    int quoted; /* a "string" in cfg, a string in JSON */
    int number; /* a JSON number (cfg words may be numbers too: 0 here) */
    int other;  /* JSON true, false, null, an object or a nested array */
    int column; /* cfg: 1-based character column; JSON: 0 */
} rd_token;

/* Where something was written: a cfg line and column, or a JSON path. */
typedef struct {
    int line, column; /* 0 when unknown */
    const char *path; /* JSON path such as "objects[3].radius", or NULL */
} rd_loc;

typedef struct {
    rd_token tok[RD_VALUE_MAX_TOKENS];
    int n;        /* tokens kept */
    int total;    /* tokens written, may exceed RD_VALUE_MAX_TOKENS */
    rd_loc loc;   /* the first token's place (or after '=' when empty) */
    int is_array; /* JSON: the value was an array */
} rd_value;

#endif
