/* Scenes read from files (load.h). No Criterion here. */
#include "load.h"

#include "scene_open.h"

rd_error_code load_scene(const char *path, rd_scene *s, rd_warnings *w, rd_error *err)
{
    rd_scene_init(s);
    rd_scene_source src = {.path = path};
    return rd_scene_open(&src, NULL, NULL, s, w, err);
}
