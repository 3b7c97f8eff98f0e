/* Ids that grant access. Whoever holds one may read what it names and,
 * where the route allows, cancel or delete it (docs/access.md): a grade's
 * verdict and images, a render's status, image and cancel. So each is
 * 128 bits from the kernel's random source, never derived from a counter,
 * a clock or another id, and they are compared in constant time.
 *
 * The ids of batches and stored jobs are the same kind (their routes also
 * need an instructor token, or are the submitter's own). Request ids in
 * logs are not capabilities and are made elsewhere (daemon/http/access.c). */
#ifndef RD_CAPABILITY_H
#define RD_CAPABILITY_H

#include <stddef.h>
#include <stdint.h>

#include "rayd/error.h"

#define RD_CAP_BITS 128
#define RD_CAP_HEX (RD_CAP_BITS / 4)
/* Room for an id: an optional one-letter kind, the digits, the NUL. */
#define RD_CAP_MAX (RD_CAP_HEX + 2)

/* Writes kind (0 for none) and RD_CAP_HEX lowercase hex digits into out.
 * RD_ERR_IO when getrandom(2) fails (out is then ""): there is no weaker
 * fallback, an id that can be guessed is worse than none. */
rd_error_code rd_cap_new(char out[RD_CAP_MAX], char kind, rd_error *err);

/* 1 when s is kind (if not 0) followed by exactly RD_CAP_HEX lowercase hex
 * digits: anything else was never an id, and is refused before a lookup. */
int rd_cap_valid(const char *s, char kind);

/* 1 when a and b are the same id. The time taken depends on their lengths
 * (at most RD_CAP_MAX bytes are read) and not on where they differ. */
int rd_cap_equal(const char *a, const char *b);

/* 64 bits of a valid id, for a hash table's bucket (the ids are uniform,
 * so any 64 of their bits spread). 0 for an invalid one. */
uint64_t rd_cap_bucket(const char *id);

#endif
