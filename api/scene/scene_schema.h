/* The JSON Schema (draft 2020-12) of the JSON scene format, generated from
 * the key table, so that the schema and the parser cannot disagree on keys,
 * types, ranges, required keys or which keys a light or material type
 * takes. Checks that need the whole scene (material names exist, geometry
 * is not degenerate, numbers are finite) are the parser's alone. */
#ifndef RD_SCENE_SCHEMA_H
#define RD_SCENE_SCHEMA_H

#include "rayd/error.h"

/* *out: malloc'ed, NUL-terminated, pretty-printed JSON ending in a newline. */
rd_error_code rd_scene_schema(char **out, rd_error *err);

#endif
