#include <cJSON.h>
#include <dirent.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "asset_source.h"
#include "file_io.h"
#include "http_internal.h"
#include "json_text.h"
#include "scene_load.h"

static int scene_file(const char *name) { return rd_ends_with(name, ".cfg") || rd_ends_with(name, ".json"); }

static int listed(const struct dirent *e) { return e->d_name[0] != '.' && scene_file(e->d_name); }

/* Links that lead out of the folder are neither listed nor served. */
static int inside(const char *dir, const char *name)
{
    char real[PATH_MAX];
    rd_error err;
    return rd_path_inside(dir, name, real, &err) == RD_OK;
}

enum MHD_Result rd_route_scenes(rd_req *r, const char *rest)
{
    const char *name = *rest ? rest + 1 : NULL;
    const char *dir = r->srv->opt.scenes_dir;
    if (!name || !*name) {
        struct dirent **names;
        int n = scandir(dir, &names, listed, alphasort);
        if (n < 0)
            return rd_reply_json(r, 200, strdup("{\"scenes\":[]}"));
        int f = 0;
        cJSON *root = cJSON_CreateObject();
        cJSON *arr = rd_json_add(root, "scenes", cJSON_CreateArray(), &f);
        for (int i = 0; i < n; i++) {
            const char *file = names[i]->d_name;
            if (arr && !f && inside(dir, file)) {
                cJSON *o = rd_json_add(arr, NULL, cJSON_CreateObject(), &f);
                int json = rd_ends_with(file, ".json");
                char base[256], url[300];
                snprintf(base, sizeof base, "%.*s", (int)(strlen(file) - (json ? 5 : 4)), file);
                snprintf(url, sizeof url, "/v1/scenes/%s", file);
                rd_json_add(o, "name", cJSON_CreateString(file), &f);
                rd_json_add(o, "scene", cJSON_CreateString(base), &f);
                rd_json_add(o, "format", cJSON_CreateString(json ? "json" : "cfg"), &f);
                rd_json_add(o, "url", cJSON_CreateString(url), &f);
            }
            free(names[i]);
        }
        free(names);
        char *t = f ? NULL : cJSON_PrintUnformatted(root);
        cJSON_Delete(root);
        if (!t)
            return rd_reply_error(r, 503, "unavailable", NULL, "out of memory");
        return rd_reply_json(r, 200, t);
    }
    /* A bare name ("phong") means its cfg; only plain file names are served. */
    char file[300];
    if (strchr(name, '/') || name[0] == '.' || strlen(name) > 200)
        return rd_reply_error(r, 404, "not_found", NULL, "no bundled scene by that name");
    snprintf(file, sizeof file, "%s%s", name, scene_file(name) ? "" : ".cfg");
    char path[PATH_MAX];
    char *text;
    size_t len;
    rd_error err = {0};
    if (rd_path_inside(dir, file, path, &err) ||
        rd_read_file(path, r->srv->opt.limits.max_bytes, rd_limit_flag(offsetof(rd_scene_limits, max_bytes)), &text,
                     &len, &err))
        return rd_reply_error(r, 404, "not_found", NULL, "no bundled scene by that name");
    const char *type = rd_ends_with(file, ".json") ? "application/json" : "text/x-rayd-cfg";
    return rd_reply(r, 200, type, text, len, 1);
}

enum MHD_Result rd_reply_page(rd_req *r, unsigned status, const char *const *headers)
{
    return rd_reply_with(r, status, "text/html; charset=utf-8", (void *)rd_web_index_html, strlen(rd_web_index_html), 0,
                         headers);
}

enum MHD_Result rd_route_page(rd_req *r, const char *rest)
{
    (void)rest;
    return rd_reply_page(r, 200, NULL);
}

enum MHD_Result rd_route_openapi(rd_req *r, const char *rest)
{
    (void)rest;
    return rd_reply(r, 200, "application/json", (void *)rd_openapi_json, strlen(rd_openapi_json), 0);
}
