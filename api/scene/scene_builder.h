/* Fills an rd_scene section by section through the one table of keys
 * (scene_keys.c), whichever format the sections come from, and checks the
 * finished scene: the cfg and JSON readers differ only in how they find
 * sections, keys and values.
 *
 * Errors come back as rd_error values whose message starts with the
 * source name and location: "scene.cfg:14:1: ..." or "scene.json: objects[2].material: ...".
 *
 * Ownership: the builder borrows the scene; rd_builder_free releases only
 * the builder's own bookkeeping. */
#ifndef RD_SCENE_BUILDER_H
#define RD_SCENE_BUILDER_H

#include "rayd/error.h"
#include "rayd/scene.h"
#include "scene_limits.h"
#include "scene_value.h"

/* No key of the format is longer; longer ones are refused before any
 * did-you-mean search. */
#define RD_MAX_KEY_BYTES 64

/* Sections hold a handful of keys; more than this is refused, so that the
 * duplicate check stays cheap. */
#define RD_MAX_SECTION_KEYS 256

typedef struct {
    const char *key; /* not NUL-terminated */
    size_t key_len;
    rd_loc key_loc;
    rd_value value;
} rd_entry;

typedef struct rd_builder rd_builder;

/* What both readers check before reading anything: the size limit, then
 * valid UTF-8 without NUL bytes (the error at the first bad byte, with its
 * line and column). */
rd_error_code rd_scene_text_check(const char *text, size_t len, const char *source, const rd_scene_limits *lim,
                                  rd_error *err);

/* source: the name used in messages ("phong.cfg", "<upload>"). The scene
 * must have been rd_scene_init'ed. NULL when out of memory. */
rd_builder *rd_builder_new(rd_scene *s, const char *source, const rd_scene_limits *lim);
void rd_builder_free(rd_builder *b);

/* One section: its kind ("sphere"), optional name, where its header is, and
 * all of its entries. */
rd_error_code rd_builder_section(rd_builder *b, const char *kind, size_t kind_len, const char *name, size_t name_len,
                                 rd_loc where, const rd_entry *entries, size_t n, rd_error *err);

/* Resolves material names and checks what needs the whole scene. */
rd_error_code rd_builder_finish(rd_builder *b, rd_error *err);

/* Formats an error at loc with the builder's source name. */
rd_error_code rd_builder_error(const rd_builder *b, rd_error *err, rd_error_code code, rd_loc loc, const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));

/* The same for readers before a builder exists. */
rd_error_code rd_loc_error(rd_error *err, rd_error_code code, const char *source, rd_loc loc, const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));

#endif
