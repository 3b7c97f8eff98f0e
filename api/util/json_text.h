/* cJSON trees as files: pretty-printed text ending in a newline. */
#ifndef RD_JSON_TEXT_H
#define RD_JSON_TEXT_H

#include <cJSON.h>

/* Prints root (and deletes it) into a malloc'ed, NUL-terminated text ending
 * in a newline, which the caller frees with free(); NULL when out of memory. */
char *rd_json_print(cJSON *root);

#endif
