/* An assignment over a term (grading.md, "A term"): when students may
 * submit, how late work is taken, what it is worth, and which of a
 * student's submissions counts. NAME.grade sets it:
 *
 *     release = 2026-11-24T09:00Z   students' submissions before it are refused
 *     due = 2026-12-01T23:59Z       a submission after it is late
 *     late_days = 3                 late work taken this many days after due (0: none)
 *     late_penalty = 0.1            share of the points lost per day late, or part of one
 *     points = 10                   what the assignment is worth (1 when not said)
 *     credit = partial              all (the points for a pass, else 0) or partial
 *     image_credit = 0.01:0.5 0.05:0.2   partial: a failing image's share by its failed fraction
 *     counts = best                 latest (the default) or best
 *
 * Times are UTC (time_text.h). A term without release or due takes every
 * submission on time. Partial credit: code earns the share of its
 * configurations that are right; an image that fails earns the share of
 * the first image_credit step whose failed fraction it does not pass
 * (none: 0). A late submission inside the window loses late_penalty of
 * the points per started day, never below 0. Everything here is a pure
 * function of its arguments. */
#ifndef RD_TERM_H
#define RD_TERM_H

#include <stddef.h>

#define RD_TERM_STEPS 8
#define RD_TERM_DAY_MS 86400000LL

typedef enum { RD_COUNTS_LATEST, RD_COUNTS_BEST } rd_counts_rule;

typedef struct {
    long long release_ms, due_ms; /* Unix milliseconds; -1: none */
    double late_days;             /* the window after due, in days; 0: none */
    double late_penalty;          /* of the points, per started day late, in [0, 1] */
    double points;                /* > 0 */
    int partial;                  /* credit = partial */
    rd_counts_rule counts;
    size_t nsteps; /* image_credit, failed fractions rising */
    struct {
        double failed_fraction, share;
    } steps[RD_TERM_STEPS];
} rd_term;

/* Everything on time, 1 point for a pass, the latest counts. */
rd_term rd_term_default(void);

/* Sets key from its text value. 1 when set; 0 when key is not one of the
 * term's; -1 when value is bad, with why (a sentence naming what was
 * expected) in why[size]. */
int rd_term_key(rd_term *t, const char *key, const char *value, char *why, size_t size);

/* Where a submission at at_ms stands. */
typedef enum {
    RD_TERM_NOT_RELEASED, /* before release: a student's is refused */
    RD_TERM_ON_TIME,
    RD_TERM_LATE,   /* after due, inside the window */
    RD_TERM_CLOSED, /* after the window: a student's is refused */
} rd_term_window;

/* The window at_ms falls in; *late_ms (may be NULL) how long after due, 0
 * when not late. */
rd_term_window rd_term_when(const rd_term *t, long long at_ms, long long *late_ms);

/* Started days of late_ms: 1 ms late is one day. */
int rd_term_late_days(long long late_ms);

/* A grade's outcome, as the score needs it. */
typedef struct {
    int graded;             /* 0: not graded (an error row): no credit */
    int pass;               /* the whole grade's */
    int code;               /* a code grade: share is its configurations right */
    double failed_fraction; /* an image's (for code, the image's) */
    double share;           /* code: configurations right / configurations */
    long long late_ms;      /* 0 on time */
} rd_term_outcome;

/* The score in [0, points], late penalty taken off; a submission after the
 * window (closed) scores 0. */
double rd_term_score(const rd_term *t, const rd_term_outcome *o);

/* One submission of a student, for rd_term_pick. */
typedef struct {
    long long submitted_ms;
    double score;
    int closed; /* after the window: never counts */
} rd_term_entry;

/* Which of one student's n submissions counts: the latest not closed
 * (latest), or the highest score, the latest of equal ones (best). -1 when
 * none may. */
long rd_term_pick(rd_counts_rule rule, const rd_term_entry *e, size_t n);

#endif
