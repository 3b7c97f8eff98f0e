/* Errors are values: a code, an optional location and a message. */
#ifndef RD_ERROR_H
#define RD_ERROR_H

typedef enum {
    RD_OK = 0,
    RD_ERR_SYNTAX,      /* malformed input text */
    RD_ERR_INVALID,     /* well-formed but invalid: unknown name, degenerate geometry */
    RD_ERR_LIMIT,       /* over a configured size limit */
    RD_ERR_IO,          /* a file could not be read or written */
    RD_ERR_NOMEM,
    RD_ERR_CANCELLED,
    RD_ERR_TIMEOUT,     /* a render ran past its time limit */
    RD_ERR_BUSY         /* no room now (queue full): try again later */
} rd_error_code;

typedef struct {
    rd_error_code code;
    int line, column;   /* 1-based; 0 when the error has no text position */
    char message[512];  /* complete, human-readable, already prefixed with the location */
} rd_error;

/* Fills err (if not NULL) with code, position and a printf-style message;
 * returns code so callers can write `return rd_error_set(...)`. */
rd_error_code rd_error_set(rd_error *err, rd_error_code code, int line, int column,
                           const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));

#endif
