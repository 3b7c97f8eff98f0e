#include "scene_open.h"

#include <stdlib.h>
#include <string.h>

#include "asset_source.h"
#include "file_io.h"
#include "scene_assets.h"

rd_error_code rd_scene_open(const rd_scene_source *src, const rd_scene_overrides *ov, const rd_scene_limits *lim_in,
                            rd_scene *s, rd_warnings *w, rd_error *err)
{
    rd_scene_limits lim = lim_in ? *lim_in : rd_scene_limits_default();
    const char *source = src->source ? src->source : src->path ? src->path : "<text>";
    rd_error_code rc;
    if (src->path) {
        rc = rd_scene_load_file_named(src->path, source, &lim, s, err);
    } else {
        rc = rd_scene_parse(src->text, src->len, src->format, source, &lim, s, err);
    }
    if (rc)
        return rc;
    if (ov)
        rd_overrides_apply(ov, s);
    rc = rd_scene_check_limits(s, &lim, source, err);
    if (rc)
        return rc;
    char *dir = src->assets_dir ? NULL : src->path ? rd_dirname(src->path) : strdup(".");
    const char *folder = src->assets_dir ? src->assets_dir : dir;
    if (!folder)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_asset_source assets = rd_asset_folder(folder);
    assets.threads = src->threads;
    rc = rd_scene_load_assets(s, &assets, &lim, w, err);
    free(dir);
    return rc;
}
