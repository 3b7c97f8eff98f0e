/* Between the daemon and rayd's evaluator (eval/eval.c, run in the
 * sandbox): the queries it is given as a file, and the frames it writes on
 * its fd 3, each a fixed header and a payload. Both ends are the same
 * build on the same machine, so the structs go as they are in memory; the
 * daemon still checks every length, count and value, since the student's
 * code shares the sandbox with the evaluator. */
#ifndef RD_CODE_FRAMES_H
#define RD_CODE_FRAMES_H

#include <stddef.h>
#include <stdint.h>

#include "rayd_code.h"

/* The evaluator's input, /rayd/queries.bin: a header, then count
 * queries, each one call of the student's calcReflectedLight. */
#define RD_QUERIES_MAGIC 0x31514452u /* "RDQ1" */
typedef struct {
    uint32_t magic;
    uint32_t count;
} rd_queries_header;

typedef struct {
    rayd_code_material m;
    rayd_code_hit h;
    double incoming[3], outgoing[3];
} rd_code_query;

enum {
    RD_FRAME_COMPILE = 1, /* rd_frame_compile, then the compiler's messages */
    RD_FRAME_VALUES = 2,  /* rd_frame_values, then count rd_frame_value */
    RD_FRAME_OUTPUT = 3,  /* rd_frame_output, then the first bytes the code printed */
    RD_FRAME_NOTE = 4     /* text: the evaluator could not do a step */
};

/* How the compile ended. */
enum { RD_COMPILE_OK = 0, RD_COMPILE_FAILED = 1, RD_COMPILE_TIME_LIMIT = 2, RD_COMPILE_OUTPUT_LIMIT = 3 };

/* How one call ended. */
enum {
    RD_VALUE_RETURNED = 0,
    RD_VALUE_CRASHED = 1,   /* a signal; rd_frame_value.signal */
    RD_VALUE_EXITED = 2,    /* the code ended the process itself */
    RD_VALUE_TIMED_OUT = 3, /* no return within the stall limit */
    RD_VALUE_NOT_RUN = 4    /* after a time-out, too many restarts or the output limit */
};

typedef struct {
    uint32_t type;
    uint32_t len; /* payload bytes after this header */
} rd_frame_header;

typedef struct {
    int32_t result; /* RD_COMPILE_* */
    int32_t status; /* the compiler's exit status, or its signal */
    double ms;
} rd_frame_compile;

typedef struct {
    uint32_t count;
    uint32_t restarts; /* fresh processes after a crash or an exit */
    double ms;
} rd_frame_values;

typedef struct {
    int32_t status; /* RD_VALUE_* */
    int32_t signal; /* CRASHED: the signal; EXITED: the exit status */
    double rgb[3];
} rd_frame_value;

typedef struct {
    uint64_t total;  /* bytes the code printed in all; the payload keeps the first */
    int32_t limited; /* it printed so much that the evaluation stopped */
    int32_t pad;
} rd_frame_output;

/* What the evaluator reported (the daemon's side, code_read.c). The fixed
 * structs are copied out (frames need not be aligned); the texts and the
 * values point into the data, which must outlive this. */
typedef struct {
    int has_compile, has_output;
    rd_frame_compile compile;
    const char *messages; /* the compiler's output, not NUL-terminated */
    size_t messages_len;
    rd_frame_values vhead;
    const unsigned char *values; /* vhead.count rd_frame_value, or NULL */
    rd_frame_output output;
    const char *printed;
    size_t printed_len;
    const char *note;
    size_t note_len;
} rd_code_frames;

/* Reads len bytes of frames; each frame's length is checked against what
 * is left, the values' count against expect (else they count as absent);
 * the first frame of each type is taken, unknown ones skipped. */
void rd_code_read_frames(const unsigned char *data, size_t len, size_t expect, rd_code_frames *f);

/* Value i (i < the count), or NOT_RUN when there are no values. */
rd_frame_value rd_code_frame_value(const rd_code_frames *f, size_t i);

#endif
