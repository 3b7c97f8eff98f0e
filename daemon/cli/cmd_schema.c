#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "scene_schema.h"

int rd_cmd_schema(int argc, char **argv)
{
    if (argc > 1 && (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0)) {
        fputs("usage: rayd schema\n\nPrints the JSON Schema of JSON scenes (docs/scene.schema.json),\n"
              "generated from the same key table as the parsers.\n",
              stdout);
        return RD_EXIT_OK;
    }
    char *text;
    rd_error err = {0};
    if (rd_scene_schema(&text, &err)) {
        fprintf(stderr, "rayd schema: %s\n", err.message);
        return RD_EXIT_IO;
    }
    fputs(text, stdout);
    free(text);
    return fflush(stdout) == 0 ? RD_EXIT_OK : RD_EXIT_IO;
}
