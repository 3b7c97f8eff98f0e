/* Instructor tokens (--instructor-tokens FILE): the routes that show
 * students' records (grade listings, exports, batches) need
 * `Authorization: Bearer TOKEN` with a token of the file. The file holds one
 * token a line; blank lines and lines starting with # are skipped; a token
 * is 16 to 256 printable ASCII characters without spaces (a shorter one is
 * refused at start, so a guessable token cannot be configured). Tokens are
 * compared in constant time: every token is read whole whatever the
 * request sent, so the answer's timing says nothing about how much of a
 * token was right. */
#ifndef RD_AUTH_H
#define RD_AUTH_H

#include "rayd/error.h"

typedef struct rd_auth rd_auth;

/* Reads the file (at most 64 KiB, 1024 tokens). NULL with err set when it
 * cannot be read, holds no token or a bad one (naming its line). Freed by
 * rd_auth_free. */
rd_auth *rd_auth_load(const char *path, rd_error *err);

void rd_auth_free(rd_auth *a);

/* How many tokens a holds (for the log). */
int rd_auth_count(const rd_auth *a);

typedef enum { RD_AUTH_OK, RD_AUTH_MISSING, RD_AUTH_WRONG } rd_auth_result;

/* authorization: the request's Authorization header (NULL when absent).
 * MISSING when there is none or it is not a Bearer token, WRONG when the
 * token is not one of the file's. */
rd_auth_result rd_auth_check(const rd_auth *a, const char *authorization);

#endif
