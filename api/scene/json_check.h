/* A strict syntax check of JSON text before cJSON builds its tree. cJSON
 * accepts more than RFC 8259 (leading zeros, "1.", control characters in
 * strings, any byte below space as white space) and reports where it
 * stopped rather than where the text went wrong; this check says, with
 * line and column, what was expected where. */
#ifndef RD_JSON_CHECK_H
#define RD_JSON_CHECK_H

#include <stddef.h>

#include "rayd/error.h"

/* Checks text (len bytes, without a byte-order mark) as one RFC 8259 JSON
 * value. Also refuses nesting deeper than max_depth (RD_ERR_LIMIT naming
 * --limit-nesting), \u0000 escapes and lone surrogates, object keys longer
 * than 64 bytes, and material names (the keys of the top-level "materials")
 * longer than max_name (RD_ERR_LIMIT naming --limit-name-bytes). Messages
 * start "source:line:col: ". */
rd_error_code rd_json_check(const char *text, size_t len, const char *source, size_t max_depth, size_t max_name,
                            rd_error *err);

#endif
