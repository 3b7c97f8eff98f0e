#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "suggest.h"
#include "version.h"

static const char help[] = "usage: rayd COMMAND [options]\n"
                           "\n"
                           "rayd is a Whitted-style ray tracer: the reference renderer of the course's\n"
                           "shading assignment (Lambert, Phong, Blinn-Phong, Cook-Torrance, mirrors, glass).\n"
                           "\n"
                           "Commands:\n"
                           "  render SCENE -o OUT.png   render a .cfg or .json scene to PNG\n"
                           "  serve [--listen H:P]      run the HTTP render service\n"
                           "  grade --assignment A --image P   grade a student's image against the reference\n"
                           "        (--dir D or several --image for a class, --csv for its table, --code F for\n"
                           "        a student's calcReflectedLight: 'rayd grade --code --help')\n"
                           "  converge SCENE            error against samples and time, with a plot\n"
                           "  convert IN OUT            turn a cfg scene into JSON or back\n"
                           "  compare A.png B.png       how two images differ (RMSE, PSNR, pixels), as JSON\n"
                           "  limits                    list the size limits and their defaults\n"
                           "  schema                    print the JSON Schema of JSON scenes\n"
                           "  version                   print the version (also --version)\n"
                           "\n"
                           "'rayd COMMAND --help' explains a command's options.\n";

static const struct {
    const char *name;
    int (*run)(int argc, char **argv);
} commands[] = {
    {"render", rd_cmd_render},   {"serve", rd_cmd_serve},     {"grade", rd_cmd_grade},   {"converge", rd_cmd_converge},
    {"convert", rd_cmd_convert}, {"compare", rd_cmd_compare}, {"limits", rd_cmd_limits}, {"schema", rd_cmd_schema},
};

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
    if (strcmp(argv[1], "--version") == 0 || strcmp(argv[1], "version") == 0) {
        printf("rayd %s\n", rd_version());
        return RD_EXIT_OK;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (strcmp(argv[1], commands[i].name) == 0)
            return commands[i].run(argc - 1, argv + 1);
    /* The scene reader's did-you-mean, over the same table that runs the
     * commands, so a new command is suggested without a second list. */
    rd_suggestion sg;
    rd_suggest_init(&sg);
    size_t len = strlen(argv[1]);
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        rd_suggest_offer(&sg, argv[1], len, commands[i].name);
    rd_suggest_offer(&sg, argv[1], len, "version");
    char hint[300];
    rd_suggest_hint(&sg, len, hint, sizeof hint);
    fprintf(stderr, "rayd: unknown command '%s'%s\n\n%s", argv[1], hint, help);
    return RD_EXIT_USAGE;
}
