/* A set of names with the line each was first seen on, for duplicate
 * checks that stay linear on scenes with many names. */
#ifndef RD_NAME_SET_H
#define RD_NAME_SET_H

#include <stddef.h>

typedef struct {
    struct rd_name_slot *slots;
    size_t cap, count;
} rd_name_set;

void rd_name_set_init(rd_name_set *s);
void rd_name_set_free(rd_name_set *s);

/* Adds (kind, name); returns -1 when it is new, else the line it was first
 * added with. -2 when out of memory. The set keeps a copy of the name. */
long rd_name_set_add(rd_name_set *s, int kind, const char *name, size_t len, int line);

#endif
