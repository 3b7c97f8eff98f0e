/* rayd's subcommands. Each takes its own argv (argv[0] is the subcommand)
 * and returns the process exit status:
 * 0 success, 1 usage, 2 scene error (nothing written), 3 I/O error. */
#ifndef RD_CLI_H
#define RD_CLI_H

enum { RD_EXIT_OK = 0, RD_EXIT_USAGE = 1, RD_EXIT_SCENE = 2, RD_EXIT_IO = 3 };

int rd_cmd_render(int argc, char **argv);
int rd_cmd_convert(int argc, char **argv);
int rd_cmd_schema(int argc, char **argv);
int rd_cmd_serve(int argc, char **argv);
int rd_cmd_converge(int argc, char **argv);
int rd_cmd_grade(int argc, char **argv);
int rd_cmd_compare(int argc, char **argv);

#include "scene_limits.h"

/* Removes every --max-NAME VALUE (or --max-NAME=VALUE) pair of the limits
 * table from argv, setting *lim; returns 0, or RD_EXIT_USAGE after printing
 * a message prefixed with who. */
int rd_cli_take_limits(int *argc, char **argv, rd_scene_limits *lim, const char *who);

/* Prints the limits and their defaults. */
int rd_cmd_limits(int argc, char **argv);

/* Parses a whole decimal integer in [lo, hi]; 0 on success. */
int rd_cli_int(const char *s, long lo, long hi, long *out);

#endif
