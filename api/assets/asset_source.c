#include "asset_source.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "file_io.h"
#include "scene_load.h"

int rd_asset_name_ok(const char *name)
{
    if (!name || !*name || name[0] == '/' || strchr(name, '\\'))
        return 0;
    const char *p = name;
    while (*p) {
        const char *slash = strchr(p, '/');
        size_t n = slash ? (size_t)(slash - p) : strlen(p);
        if (n == 0 || (n == 1 && p[0] == '.') || (n == 2 && p[0] == '.' && p[1] == '.'))
            return 0;
        p += n;
        if (*p == '/')
            p++;
    }
    return 1;
}

rd_error_code rd_path_inside(const char *dir, const char *name, char *real_file, rd_error *err)
{
    char full[PATH_MAX];
    if ((size_t)snprintf(full, PATH_MAX, "%s/%s", dir, name) >= PATH_MAX)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "'%.200s': path too long", name);
    /* A symbolic link may still point outside: compare the real paths. */
    char real_dir[PATH_MAX];
    if (!realpath(dir, real_dir))
        return rd_error_set(err, RD_ERR_IO, 0, 0, "%s: %s", dir, strerror(errno));
    if (!realpath(full, real_file))
        return rd_error_set(err, RD_ERR_IO, 0, 0, "'%.200s': %s", name, strerror(errno));
    size_t dl = strlen(real_dir);
    if (strncmp(real_file, real_dir, dl) != 0 || (real_file[dl] != '/' && dl != 1))
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "'%.200s' leads outside the scene's folder", name);
    return RD_OK;
}

static rd_error_code folder_read(const rd_asset_source *src, const char *name, size_t max_bytes, const char *flag,
                                 unsigned char **data, size_t *len, rd_error *err)
{
    *data = NULL;
    *len = 0;
    if (!rd_asset_name_ok(name))
        return rd_error_set(err, RD_ERR_INVALID, 0, 0,
                            "'%.200s' is not a path inside the scene's folder (no absolute paths, no '..')", name);
    char real_file[PATH_MAX];
    rd_error_code rc = rd_path_inside(src->dir, name, real_file, err);
    if (rc)
        return rc;
    char *text;
    rc = rd_read_file_threads(real_file, max_bytes, flag, src->threads, &text, len, err);
    if (rc == RD_OK)
        *data = (unsigned char *)text;
    else if (rc == RD_ERR_IO || rc == RD_ERR_LIMIT) {
        /* Name the asset as the scene wrote it, not the resolved path. */
        char m[sizeof err->message];
        snprintf(m, sizeof m, "%s", err->message);
        const char *colon = strstr(m, ": ");
        rd_error_set(err, rc, 0, 0, "'%.200s'%s", name, colon ? colon : "");
    }
    return rc;
}

rd_asset_source rd_asset_folder(const char *dir)
{
    rd_asset_source s;
    memset(&s, 0, sizeof s);
    s.read = folder_read;
    s.dir = dir;
    return s;
}
