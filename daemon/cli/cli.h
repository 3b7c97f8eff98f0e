/* rayd's subcommands. Each takes its own argv (argv[0] is the subcommand)
 * and returns the process exit status, RD_EXIT_* (error_map.h): 0 success,
 * 1 usage, 2 scene or image error (nothing written), 3 I/O error, and for
 * rayd grade 4, graded and failing. */
#ifndef RD_CLI_H
#define RD_CLI_H

#include <stdio.h>

#include "error_map.h"
#include "grading.h"
#include "scene_limits.h"
#include "scene_overrides.h"

int rd_cmd_render(int argc, char **argv);
int rd_cmd_convert(int argc, char **argv);
int rd_cmd_schema(int argc, char **argv);
int rd_cmd_serve(int argc, char **argv);
int rd_cmd_converge(int argc, char **argv);
int rd_cmd_grade(int argc, char **argv);
/* Writes the heat map of where o's image differs from its reference as a
 * PNG file at path. */
rd_error_code rd_cli_write_diff(const rd_grade_output *o, const char *path, rd_error *err);
/* Writes o's heat map to diff (when both are given) and prints verdict
 * (which it deletes); status, or RD_EXIT_IO when the heat map could not be
 * written, RD_EXIT_SCENE when out of memory. */
int rd_cli_grade_report(cJSON *verdict, const rd_grade_output *o, const char *diff, int status);
/* rayd grade --code: a student's calcReflectedLight (cmd_grade_code.c). */
int rd_cmd_grade_code(int argc, char **argv);
int rd_cmd_compare(int argc, char **argv);

/* Removes every --limit-NAME VALUE (or --limit-NAME=VALUE) pair of the
 * limits table from argv, setting *lim; the old --max-NAME spellings too,
 * with a warning on stderr, but for the flag own (NULL: none), which the
 * command uses for something else; returns 0, or RD_EXIT_USAGE after
 * printing a message prefixed with who. */
int rd_cli_take_limits(int *argc, char **argv, rd_scene_limits *lim, const char *who, const char *own);

/* Each limit from its environment variable, RAYD_ and the flag's name in
 * capitals (--limit-depth: RAYD_LIMIT_DEPTH), when set; 0 or RD_EXIT_USAGE. */
int rd_cli_limits_from_env(rd_scene_limits *lim, const char *who);

/* Removes every render override from argv: --NAME VALUE (or --NAME=VALUE)
 * for each of rd_override_names, '_' written '-', and --set render.KEY=VALUE,
 * read into *ov by rd_override_set (the check of the query parameters).
 * skip: NULL-terminated names the command sets itself, not taken (NULL:
 * none). Returns 0, or RD_EXIT_USAGE after printing a message prefixed
 * with who. */
int rd_cli_take_overrides(int *argc, char **argv, rd_scene_overrides *ov, const char *who, const char *const *skip);

/* The help text of those flags. */
void rd_cli_overrides_help(FILE *f, const char *const *skip);

/* Prints the limits and their defaults. */
int rd_cmd_limits(int argc, char **argv);

/* Parses a whole decimal integer in [lo, hi]; 0 on success. */
int rd_cli_int(const char *s, long lo, long hi, long *out);

#endif
