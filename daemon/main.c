#include <stdio.h>
#include <string.h>

#include "cli.h"

static const char help[] =
    "usage: rayd COMMAND [options]\n"
    "\n"
    "rayd is a Whitted-style ray tracer: the reference renderer of the course's\n"
    "shading assignment (Lambert, Phong, Blinn-Phong, Cook-Torrance, mirrors, glass).\n"
    "\n"
    "Commands:\n"
    "  render SCENE -o OUT.png   render a .cfg or .json scene to PNG\n"
    "  serve [--listen H:P]      run the HTTP render service\n"
    "  grade --assignment A --image P   grade a student's image against the reference\n"
    "  converge SCENE            error against samples and time, with a plot\n"
    "  convert IN OUT            turn a cfg scene into JSON or back\n"
    "  compare A.png B.png       how two images differ (RMSE, PSNR, pixels), as JSON\n"
    "  limits                    list the size limits and their defaults\n"
    "  schema                    print the JSON Schema of JSON scenes\n"
    "\n"
    "'rayd COMMAND --help' explains a command's options.\n";

int main(int argc, char **argv)
{
    if (argc < 2) {
        fputs(help, stderr);
        return RD_EXIT_USAGE;
    }
    if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "help") == 0) {
        fputs(help, stdout);
        return RD_EXIT_OK;
    }
    if (strcmp(argv[1], "render") == 0)
        return rd_cmd_render(argc - 1, argv + 1);
    if (strcmp(argv[1], "grade") == 0)
        return rd_cmd_grade(argc - 1, argv + 1);
    if (strcmp(argv[1], "converge") == 0)
        return rd_cmd_converge(argc - 1, argv + 1);
    if (strcmp(argv[1], "serve") == 0)
        return rd_cmd_serve(argc - 1, argv + 1);
    if (strcmp(argv[1], "schema") == 0)
        return rd_cmd_schema(argc - 1, argv + 1);
    if (strcmp(argv[1], "limits") == 0)
        return rd_cmd_limits(argc - 1, argv + 1);
    if (strcmp(argv[1], "convert") == 0)
        return rd_cmd_convert(argc - 1, argv + 1);
    if (strcmp(argv[1], "compare") == 0)
        return rd_cmd_compare(argc - 1, argv + 1);
    fprintf(stderr, "rayd: unknown command '%s'\n\n%s", argv[1], help);
    return RD_EXIT_USAGE;
}
