/* The answers of a world's ray queries by their definition
 * (core/geometry/prim.h), not by any walk: the reference every walk must
 * match to the bit, whatever its node width, box test, order or packets
 * (tests/unit/core/test_walk.c, tests/fuzz/fuzz_walk.c).
 *
 * The closest hit is the least (t, id) over the hits that count: a
 * primitive's own hit with t below the limit, in a leaf whose box the
 * ray's robust double slab test accepts, at or beyond that leaf's floor.
 * The oracle finds it exhaustively: it visits every node and leaf the test
 * accepts within the search's first cut, in child order, with no skipping.
 * A leaf a walk skips or rejects under a later, smaller cut holds nothing
 * that wins (prim.h), so both give the same answer; where they do not, the
 * walk broke the rule. Any-hit: some primitive of an accepted leaf is hit
 * before tmax (no floor). Worlds without a BVH: their plain loops, which
 * are the definition there.
 *
 * Slow by design (every leaf on the ray's line is opened); for tests. */
#ifndef RD_TEST_WALK_ORACLE_H
#define RD_TEST_WALK_ORACLE_H

#include <stddef.h>

#include "world.h"

/* What rd_world_closest must answer: 1 and h filled as it fills it, or 0;
 * -1 for a tree deeper than the walks' stack (none rd_world_build makes). */
int walk_oracle_closest(const rd_world *w, rd_ray r, double tmax, rd_hit *h);

/* What rd_world_any (and rd_world_any_hint, any hint) must answer; -1 as
 * above. */
int walk_oracle_any(const rd_world *w, rd_ray r, double tmax);

/* 1 when a and b agree field by field (doubles bit for bit; bary only for
 * triangles, u and v not at all: rd_world_closest leaves them); else 0
 * and the first field that differs, with both values, in why[0..n). */
int walk_oracle_same_hit(const rd_hit *a, const rd_hit *b, char *why, size_t n);

#endif
