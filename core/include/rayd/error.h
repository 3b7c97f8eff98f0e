/* Errors are values: a code, an optional location and a message.
 *
 * RD_ERRORS is the one list of codes: each with its stable name (logs,
 * JSON, tests) and what it means. A meaning gets its own code rather than
 * borrowing a near one, so that every layer can map a code to an answer
 * without knowing where it came from (daemon/errors/ maps them to HTTP
 * statuses and exit codes, once). */
#ifndef RD_ERROR_H
#define RD_ERROR_H

#define RD_ERRORS(X)                                                                                                   \
    X(RD_OK, "ok", "success")                                                                                          \
    X(RD_ERR_SYNTAX, "syntax", "malformed input: scene or assignment text, image bytes")                               \
    X(RD_ERR_INVALID, "invalid", "well-formed but invalid: unknown name, degenerate geometry, wrong size")             \
    X(RD_ERR_LIMIT, "limit", "over a configured size limit")                                                           \
    X(RD_ERR_IO, "io", "a file could not be read or written")                                                          \
    X(RD_ERR_NOMEM, "nomem", "out of memory")                                                                          \
    X(RD_ERR_CANCELLED, "cancelled", "stopped on request")                                                             \
    X(RD_ERR_TIMEOUT, "timeout", "a render ran past its time limit")                                                   \
    X(RD_ERR_BUSY, "busy", "no room now (queue full): try again later")                                                \
    X(RD_ERR_NOT_FOUND, "not_found", "nothing of that name: assignment, scene, job")                                   \
    X(RD_ERR_UNSUPPORTED, "unsupported", "a kind of input it does not read (not a PNG)")                               \
    X(RD_ERR_NOSPACE, "nospace", "no space left to write: a full disk, a store at its size limit")                     \
    X(RD_ERR_DAMAGED, "damaged", "stored data is damaged: a corrupt page, not a database")                             \
    X(RD_ERR_UNAVAILABLE, "unavailable", "a service it needs cannot be used now (store unreachable, no sandbox)")

typedef enum {
#define RD_ERROR_ENUM(code, name, meaning) code,
    RD_ERRORS(RD_ERROR_ENUM)
#undef RD_ERROR_ENUM
        RD_ERROR_COUNT
} rd_error_code;

typedef struct {
    rd_error_code code;
    int line, column;  /* 1-based; 0 when the error has no text position */
    char message[512]; /* complete, human-readable, already prefixed with the location */
} rd_error;

/* Fills err (if not NULL) with code, position and a printf-style message;
 * returns code so callers can write `return rd_error_set(...)`. */
rd_error_code rd_error_set(rd_error *err, rd_error_code code, int line, int column, const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));

/* The code's stable name ("syntax", "not_found"); "?" for a value outside
 * the list. */
const char *rd_error_name(rd_error_code code);

#endif
