/* Scenes read from files as `rayd render FILE` reads them (rd_scene_open):
 * the file with the default limits (rd_scene_limits_default), then its
 * meshes and textures from the file's own folder.
 *
 * load_scene is plain C, without Criterion, so that tests/stability (which
 * `make stability` links into a program of its own) shares it. load_cfg is
 * its form for Criterion tests: a macro, so that neither this header nor
 * load.c needs Criterion, and a failure points at the test's own line. */
#ifndef RD_TEST_LOAD_H
#define RD_TEST_LOAD_H

#include "obj_load.h"
#include "rayd/error.h"
#include "rayd/scene.h"

/* Loads the scene file at path (.cfg, .json, or sniffed) into s, which it
 * rd_scene_init's first; the caller frees s either way. Warnings go to w
 * (NULL: dropped). RD_OK, or the first error with its message in err. */
rd_error_code load_scene(const char *path, rd_scene *s, rd_warnings *w, rd_error *err);

/* load_scene, failing the current Criterion test with the path and the
 * message on any error. */
#define load_cfg(path, s)                                                                                              \
    do {                                                                                                               \
        const char *load_path_ = (path);                                                                               \
        rd_error load_err_ = {0};                                                                                      \
        rd_error_code load_rc_ = load_scene(load_path_, (s), NULL, &load_err_);                                        \
        cr_assert_eq(load_rc_, RD_OK, "%s: %s", load_path_, load_err_.message);                                        \
    } while (0)

#endif
