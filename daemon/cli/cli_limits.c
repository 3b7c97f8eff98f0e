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

/* Whether a is flag, alone or as flag=VALUE. */
static int is_flag(const char *a, const char *flag)
{
    size_t n = flag ? strlen(flag) : 0;
    return n && strncmp(a, flag, n) == 0 && (a[n] == 0 || a[n] == '=');
}

/* The limit a names, by its name or its old one (but not own); *old is set
 * when it was the old name. */
static const rd_limit_info *limit_of(const char *a, const char *own, int *old)
{
    size_t n;
    const rd_limit_info *info = rd_limits_info(&n);
    if (is_flag(a, own))
        return NULL;
    for (size_t k = 0; k < n; k++) {
        *old = is_flag(a, info[k].old);
        if (is_flag(a, info[k].flag) || *old)
            return &info[k];
    }
    return NULL;
}

int rd_cli_take_limits(int *argc, char **argv, rd_scene_limits *lim, const char *who, const char *own)
{
    int out = 0;
    for (int i = 0; i < *argc; i++) {
        const char *a = argv[i];
        int old = 0;
        const rd_limit_info *hit = strncmp(a, "--", 2) == 0 ? limit_of(a, own, &old) : NULL;
        if (!hit) {
            argv[out++] = argv[i];
            continue;
        }
        const char *eq = strchr(a, '=');
        const char *value = eq ? eq + 1 : i + 1 < *argc ? argv[++i] : NULL;
        if (old)
            fprintf(stderr, "%s: warning: %s is deprecated and goes in the next release; use %s\n", who, hit->old,
                    hit->flag);
        if (set_limit(lim, hit, value, who, old ? hit->old : hit->flag))
            return RD_EXIT_USAGE;
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
        printf("  %-24s %12zu  %s\n", info[i].flag, *(const size_t *)((const char *)&d + info[i].offset), info[i].what);
    printf("\nThe old names --max-NAME still work for one release, with a warning, but for\n"
           "--max-depth: that is now the render override of the scene's max_depth.\n");
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
