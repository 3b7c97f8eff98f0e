#include "scene_load.h"

#include <errno.h>
#include <fcntl.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cfg_parse.h"
#include "file_io.h"
#include "json_parse.h"
#include "utf8.h"

rd_scene_format rd_scene_sniff(const char *text, size_t len)
{
    size_t i = rd_utf8_bom(text, len);
    while (i < len && (text[i] == ' ' || text[i] == '\t' || text[i] == '\r' || text[i] == '\n'))
        i++;
    return i < len && text[i] == '{' ? RD_FMT_JSON : RD_FMT_CFG;
}

rd_error_code rd_scene_parse(const char *text, size_t len, rd_scene_format fmt, const char *source,
                             const rd_scene_limits *lim, rd_scene *s, rd_error *err)
{
    if (fmt == RD_FMT_AUTO)
        fmt = rd_scene_sniff(text, len);
    if (fmt == RD_FMT_JSON)
        return rd_json_parse(text, len, source, lim, s, err);
    return rd_cfg_parse(text, len, source, lim, s, err);
}

rd_error_code rd_scene_load_file(const char *path, const rd_scene_limits *lim_in, rd_scene *s, rd_error *err)
{
    return rd_scene_load_file_named(path, path, lim_in, s, err);
}

rd_error_code rd_scene_load_file_named(const char *path, const char *name, const rd_scene_limits *lim_in, rd_scene *s,
                                       rd_error *err)
{
    rd_scene_limits lim = lim_in ? *lim_in : rd_scene_limits_default();
    char *text;
    size_t len;
    rd_error_code rc =
        rd_read_file(path, lim.max_bytes, rd_limit_flag(offsetof(rd_scene_limits, max_bytes)), &text, &len, err);
    if (rc)
        return rc;
    rd_scene_format fmt = rd_ends_with(path, ".json")  ? RD_FMT_JSON
                          : rd_ends_with(path, ".cfg") ? RD_FMT_CFG
                                                       : RD_FMT_AUTO;
    rc = rd_scene_parse(text, len, fmt, name, &lim, s, err);
    free(text);
    return rc;
}
