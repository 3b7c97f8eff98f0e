#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "file_io.h"
#include "png_write.h"
#include "scene_load.h"
#include "scene_open.h"
#include "scene_write.h"

static const char convert_help[] = "usage: rayd convert IN OUT [--to cfg|json] [--expand [--limit-... N]]\n"
                                   "\n"
                                   "Reads the scene IN (.cfg or .json; other names are sniffed) and writes the\n"
                                   "same scene to OUT in the other format, or the one OUT's extension names.\n"
                                   "OUT '-' writes to standard output (give --to). Comments are not kept; every\n"
                                   "key that differs from its default is written, so converting the result\n"
                                   "again gives the same text.\n"
                                   "\n"
                                   "  --expand   JSON only: the scene as rayd renders it, for other programs\n"
                                   "             (bench/cfg2pov.py): every key with its value, defaults\n"
                                   "             included, and each mesh object with a member \"loaded\": the\n"
                                   "             OBJ as rayd reads it, in world coordinates (translate, scale,\n"
                                   "             rotate applied), polygons fanned: {\"positions\": [[x,y,z],\n"
                                   "             ...], \"normals\": [...], \"faces\": [[v0,v1,v2,n0,n1,n2],\n"
                                   "             ...]}, indices from 0, n -1 where a corner has no normal;\n"
                                   "             rayd itself refuses \"loaded\" when reading a scene\n"
                                   "  --limit-...  N  the size limits of 'rayd limits' for the scene and its\n"
                                   "               meshes (a mesh of a million triangles needs --limit-objects)\n"
                                   "\n"
                                   "Exit status: 0 written; 1 usage error; 2 scene error; 3 I/O error.\n";

int rd_cmd_convert(int argc, char **argv)
{
    const char *in = NULL, *out = NULL, *to = NULL;
    int expand = 0;
    rd_scene_limits lim = rd_scene_limits_default();
    int lrc = rd_cli_take_limits(&argc, argv, &lim, "rayd convert", NULL);
    if (lrc)
        return lrc;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            fputs(convert_help, stdout);
            return RD_EXIT_OK;
        } else if (strcmp(argv[i], "--expand") == 0) {
            expand = 1;
        } else if (strcmp(argv[i], "--to") == 0 && i + 1 < argc) {
            to = argv[++i];
        } else if (argv[i][0] == '-' && argv[i][1] != 0) {
            fprintf(stderr, "rayd convert: unknown option '%s'\n(try 'rayd convert --help')\n", argv[i]);
            return RD_EXIT_USAGE;
        } else if (!in) {
            in = argv[i];
        } else if (!out) {
            out = argv[i];
        } else {
            fprintf(stderr, "rayd convert: expected IN and OUT only\n");
            return RD_EXIT_USAGE;
        }
    }
    if (!in || !out) {
        fprintf(stderr, "rayd convert: expected IN and OUT\n(try 'rayd convert --help')\n");
        return RD_EXIT_USAGE;
    }
    int json;
    if (to)
        json = strcmp(to, "json") == 0 ? 1 : (strcmp(to, "cfg") == 0 ? 0 : -1);
    else if (rd_ends_with(out, ".json"))
        json = 1;
    else if (rd_ends_with(out, ".cfg"))
        json = 0;
    else
        json = -2;
    if (json == -1) {
        fprintf(stderr, "rayd convert: --to takes cfg or json, not '%s'\n", to);
        return RD_EXIT_USAGE;
    }
    if (json == -2) {
        fprintf(stderr, "rayd convert: cannot tell the format of '%s': name it .cfg or .json, or give --to\n", out);
        return RD_EXIT_USAGE;
    }
    if (expand && json != 1) {
        fprintf(stderr, "rayd convert: --expand writes JSON only\n");
        return RD_EXIT_USAGE;
    }
    rd_scene s;
    rd_scene_init(&s);
    rd_error err = {0};
    /* Expanded, the scene is opened as for a render: with its meshes. */
    rd_scene_source src = {.path = in};
    rd_warnings warnings = {0, ""};
    rd_error_code rc =
        expand ? rd_scene_open(&src, NULL, &lim, &s, &warnings, &err) : rd_scene_load_file(in, &lim, &s, &err);
    if (warnings.count)
        fprintf(stderr, "%s%s", warnings.text, warnings.count > 5 ? "(more warnings not shown)\n" : "");
    char *text = NULL;
    rd_scene_write_options wo = {.every_key = expand, .loaded_meshes = expand};
    if (!rc)
        rc = json ? rd_scene_write_json_with(&s, &wo, &text, &err) : rd_scene_write_cfg(&s, &text, &err);
    rd_scene_free(&s);
    if (rc) {
        fprintf(stderr, "%s\n", err.message);
        return rd_error_answer_for(rc).exit;
    }
    if (strcmp(out, "-") == 0) {
        fputs(text, stdout);
        rc = fflush(stdout) == 0 ? RD_OK : rd_error_set(&err, RD_ERR_IO, 0, 0, "cannot write to stdout");
    } else {
        rc = rd_write_file(out, text, strlen(text), &err);
    }
    free(text);
    if (rc) {
        fprintf(stderr, "rayd convert: %s\n", err.message);
        return RD_EXIT_IO;
    }
    return RD_EXIT_OK;
}
