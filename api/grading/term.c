#include "term.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "time_text.h"

rd_term rd_term_default(void)
{
    rd_term t;
    memset(&t, 0, sizeof t);
    t.release_ms = t.due_ms = -1;
    t.points = 1;
    t.counts = RD_COUNTS_LATEST;
    return t;
}

static int bad(char *why, size_t size, const char *expected)
{
    snprintf(why, size, "expected %s", expected);
    return -1;
}

/* A number in [lo, hi] (and > lo when open), whole text. */
static int number_in(const char *v, double lo, double hi, int open, double *out)
{
    char *end;
    double x = strtod(v, &end);
    if (!*v || *end || !isfinite(x) || x < lo || x > hi || (open && x == lo))
        return 0;
    *out = x;
    return 1;
}

/* "F:S F:S ...": failed fraction and share pairs, fractions rising, shares
 * in [0, 1]. */
static int parse_steps(rd_term *t, const char *v)
{
    size_t n = 0;
    const char *p = v;
    while (*p) {
        char *end;
        double f = strtod(p, &end);
        if (end == p || *end != ':' || n == RD_TERM_STEPS || !(f >= 0 && f <= 1))
            return 0;
        p = end + 1;
        double s = strtod(p, &end);
        if (end == p || !(s >= 0 && s <= 1) || (*end && *end != ' ' && *end != '\t'))
            return 0;
        if (n && f <= t->steps[n - 1].failed_fraction)
            return 0;
        t->steps[n].failed_fraction = f;
        t->steps[n++].share = s;
        p = end + strspn(end, " \t");
    }
    t->nsteps = n;
    return n > 0;
}

int rd_term_key(rd_term *t, const char *key, const char *value, char *why, size_t size)
{
    if (strcmp(key, "release") == 0 || strcmp(key, "due") == 0) {
        long long ms = rd_time_parse(value);
        if (ms < 0)
            return bad(why, size, "a UTC time as 2026-12-01T23:59Z (or a date, 2026-12-01)");
        *(strcmp(key, "due") == 0 ? &t->due_ms : &t->release_ms) = ms;
        return 1;
    }
    if (strcmp(key, "late_days") == 0)
        return number_in(value, 0, 366, 0, &t->late_days) ? 1 : bad(why, size, "a number of days in 0..366");
    if (strcmp(key, "late_penalty") == 0)
        return number_in(value, 0, 1, 0, &t->late_penalty) ? 1 : bad(why, size, "a share of the points in [0, 1]");
    if (strcmp(key, "points") == 0)
        return number_in(value, 0, 1e6, 1, &t->points) ? 1 : bad(why, size, "a number of points > 0");
    if (strcmp(key, "credit") == 0) {
        if (strcmp(value, "all") != 0 && strcmp(value, "partial") != 0)
            return bad(why, size, "all or partial");
        t->partial = strcmp(value, "partial") == 0;
        return 1;
    }
    if (strcmp(key, "counts") == 0) {
        if (strcmp(value, "latest") != 0 && strcmp(value, "best") != 0)
            return bad(why, size, "latest or best");
        t->counts = strcmp(value, "best") == 0 ? RD_COUNTS_BEST : RD_COUNTS_LATEST;
        return 1;
    }
    if (strcmp(key, "image_credit") == 0)
        return parse_steps(t, value) ? 1
                                     : bad(why, size,
                                           "failed-fraction:share pairs, fractions rising, as 0.01:0.5 0.05:0.2 "
                                           "(at most 8)");
    return 0;
}

rd_term_window rd_term_when(const rd_term *t, long long at_ms, long long *late_ms)
{
    if (late_ms)
        *late_ms = 0;
    if (t->release_ms >= 0 && at_ms < t->release_ms)
        return RD_TERM_NOT_RELEASED;
    if (t->due_ms < 0 || at_ms <= t->due_ms)
        return RD_TERM_ON_TIME;
    if (late_ms)
        *late_ms = at_ms - t->due_ms;
    /* The window in whole milliseconds, so that its last instant is exact. */
    long long window = llround(t->late_days * (double)RD_TERM_DAY_MS);
    return at_ms - t->due_ms <= window ? RD_TERM_LATE : RD_TERM_CLOSED;
}

int rd_term_late_days(long long late_ms)
{
    return late_ms <= 0 ? 0 : (int)((late_ms + RD_TERM_DAY_MS - 1) / RD_TERM_DAY_MS);
}

/* The share of the points the work earns before any penalty. */
static double earned_share(const rd_term *t, const rd_term_outcome *o)
{
    if (!o->graded)
        return 0;
    if (o->pass)
        return 1;
    if (!t->partial)
        return 0;
    if (o->code)
        return isfinite(o->share) && o->share > 0 ? fmin(o->share, 1) : 0;
    for (size_t i = 0; i < t->nsteps; i++)
        if (o->failed_fraction <= t->steps[i].failed_fraction)
            return t->steps[i].share;
    return 0;
}

double rd_term_score(const rd_term *t, const rd_term_outcome *o)
{
    long long late = o->late_ms > 0 ? o->late_ms : 0;
    long long window = llround(t->late_days * (double)RD_TERM_DAY_MS);
    if (late > window)
        return 0;
    double score = t->points * earned_share(t, o) - t->points * t->late_penalty * rd_term_late_days(late);
    return score > 0 ? score : 0;
}

long rd_term_pick(rd_counts_rule rule, const rd_term_entry *e, size_t n)
{
    long best = -1;
    for (size_t i = 0; i < n; i++) {
        if (e[i].closed)
            continue;
        if (best < 0) {
            best = (long)i;
            continue;
        }
        const rd_term_entry *b = &e[best];
        int later = e[i].submitted_ms >= b->submitted_ms;
        if (rule == RD_COUNTS_LATEST ? later : e[i].score > b->score || (e[i].score == b->score && later))
            best = (long)i;
    }
    return best;
}
