/* Scenes read from files (load.h). No Criterion here. */
#include "load.h"

#include <stdlib.h>

#include "asset_source.h"
#include "file_io.h"
#include "scene_assets.h"
#include "scene_limits.h"
#include "scene_load.h"

rd_error_code load_scene(const char *path, rd_scene *s, rd_warnings *w, rd_error *err)
{
    rd_scene_init(s);
    rd_scene_limits lim = rd_scene_limits_default();
    rd_error_code rc = rd_scene_load_file(path, &lim, s, err);
    if (rc != RD_OK)
        return rc;
    char *dir = rd_dirname(path);
    if (!dir)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory for the folder of %s", path);
    rd_asset_source src = rd_asset_folder(dir);
    rc = rd_scene_load_assets(s, &src, &lim, w, err);
    free(dir);
    return rc;
}
