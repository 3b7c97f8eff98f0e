/* The hashes and ids of api/ and daemon/: one of each kind. None defends
 * against forgery; they name and spread, they do not authenticate. */
#ifndef RD_HASH_H
#define RD_HASH_H

#include <stddef.h>
#include <stdint.h>

#define RD_FNV_OFFSET 0xcbf29ce484222325ULL

/* FNV-1a, 64 bits, continuing from h (start with RD_FNV_OFFSET): cache
 * keys and hash tables. */
uint64_t rd_fnv1a(uint64_t h, const void *data, size_t n);

/* The SplitMix64 finaliser: a bijection that turns a counter into ids
 * that look random. */
uint64_t rd_mix64(uint64_t z);

/* 64 bits from the kernel's random source (the clock, mixed, if that is
 * unavailable): the secret that makes a process's ids unguessable from
 * one another. */
uint64_t rd_random_key(void);

#endif
