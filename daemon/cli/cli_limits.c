#include <ctype.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"

/* A positive integer into the limit; 1 after a message naming from. */
static int set_limit(rd_scene_limits *lim, const rd_limit_info *info, const char *value, const char *who,
                     const char *from)
{
    char *end;
    errno = 0;
    unsigned long long v = value && *value && *value != '-' ? strtoull(value, &end, 10) : 0;
    if (!value || !*value || *value == '-' || *end || errno || v == 0) {
        fprintf(stderr, "%s: %s: expected a positive integer, got '%s'\n", who, from, value ? value : "");
        return 1;
    }
    *(size_t *)((char *)lim + info->offset) = (size_t)v;
    return 0;
}

int rd_cli_take_limits(int *argc, char **argv, rd_scene_limits *lim, const char *who, const char *own)
{
    size_t n;
    const rd_limit_info *info = rd_limits_info(&n);
    int out = 0;
    for (int i = 0; i < *argc; i++) {
        const char *a = argv[i];
        const rd_limit_info *hit = NULL;
        const char *value = NULL;
        int used = 1;
        if (strncmp(a, "--max-", 6) == 0 &&
            !(own && strncmp(a, own, strlen(own)) == 0 && (a[strlen(own)] == 0 || a[strlen(own)] == '='))) {
            for (size_t k = 0; k < n && !hit; k++) {
                size_t fl = strlen(info[k].flag);
                if (strncmp(a, info[k].flag, fl) == 0 && (a[fl] == 0 || a[fl] == '=')) {
                    hit = &info[k];
                    if (a[fl] == '=') {
                        value = a + fl + 1;
                    } else if (i + 1 < *argc) {
                        value = argv[i + 1];
                        used = 2;
                    }
                }
            }
            /* Not a scene limit: the command's own flag (serve has
             * --max-body-bytes and others) or a mistake it reports. */
        }
        if (!hit) {
            argv[out++] = argv[i];
            continue;
        }
        if (set_limit(lim, hit, value, who, hit->flag))
            return RD_EXIT_USAGE;
        i += used - 1;
    }
    argv[out] = NULL;
    *argc = out;
    return 0;
}

int rd_cli_limits_from_env(rd_scene_limits *lim, const char *who)
{
    size_t n;
    const rd_limit_info *info = rd_limits_info(&n);
    for (size_t k = 0; k < n; k++) {
        char env[64];
        size_t len = (size_t)snprintf(env, sizeof env, "RAYD_");
        for (const char *f = info[k].flag + 2; *f && len + 1 < sizeof env; f++)
            env[len++] = *f == '-' ? '_' : (char)toupper((unsigned char)*f);
        env[len] = 0;
        const char *v = getenv(env);
        if (v && set_limit(lim, &info[k], v, who, env))
            return RD_EXIT_USAGE;
    }
    return 0;
}

int rd_cmd_limits(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    size_t n;
    const rd_limit_info *info = rd_limits_info(&n);
    rd_scene_limits d = rd_scene_limits_default();
    printf("Size limits on scene input (flags of 'rayd render', 'converge', 'grade' and 'serve'):\n\n");
    for (size_t i = 0; i < n; i++)
        printf("  %-22s %12zu  %s\n", info[i].flag, *(const size_t *)((const char *)&d + info[i].offset), info[i].what);
    return RD_EXIT_OK;
}

int rd_cli_int(const char *s, long lo, long hi, long *out)
{
    if (!s || !*s)
        return 1;
    char *end;
    long v = strtol(s, &end, 10);
    if (*end || v < lo || v > hi)
        return 1;
    *out = v;
    return 0;
}
