/* "Did you mean": the closest of a set of words to a misspelling. */
#ifndef RD_SUGGEST_H
#define RD_SUGGEST_H

#include <stddef.h>

/* Tracks the best candidate seen so far. */
typedef struct {
    const char *best;
    int dist;
} rd_suggestion;

void rd_suggest_init(rd_suggestion *s);
void rd_suggest_offer(rd_suggestion *s, const char *typed, size_t len, const char *candidate);

/* The best candidate if it is close enough to be a likely typo (distance at
 * most 2, and at most a third of the longer word), else NULL. */
const char *rd_suggest_result(const rd_suggestion *s, size_t typed_len);

/* What messages append: "; did you mean 'WORD'?" for the result, or "" when
 * there is none. Written into buf (at least 300 bytes for any word), which
 * it returns. */
const char *rd_suggest_hint(const rd_suggestion *s, size_t typed_len, char *buf, size_t size);

#endif
