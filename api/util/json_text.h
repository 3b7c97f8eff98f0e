/* cJSON trees as files: pretty-printed text ending in a newline. */
#ifndef RD_JSON_TEXT_H
#define RD_JSON_TEXT_H

#include <cJSON.h>

#include "rayd/progress.h"

/* Prints root (and deletes it) into a malloc'ed, NUL-terminated text ending
 * in a newline, which the caller frees with free(); NULL when out of memory. */
char *rd_json_print(cJSON *root);

/* Adds item to parent, under key when parent is an object (key NULL: to
 * the end of an array), and returns item. When item or parent is NULL or
 * the add fails (cJSON out of memory), deletes item, sets *failed and
 * returns NULL: a tree is built without a check at every step and checked
 * once, through *failed, at the end. */
cJSON *rd_json_add(cJSON *parent, const char *key, cJSON *item, int *failed);

/* An error-against-time curve as the HTTP answers give it: [[ms, samples,
 * error], ...] (NULL when out of memory). */
cJSON *rd_json_curve(const rd_curve_point *c, int n);

#endif
