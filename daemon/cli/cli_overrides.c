#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "scene_keys.h"

/* "--max-depth" for "max_depth". */
static void flag_of(const char *name, char *out, size_t size)
{
    snprintf(out, size, "--%s", name);
    for (char *p = out + 2; *p; p++)
        if (*p == '_')
            *p = '-';
}

static int skipped(const char *name, const char *const *skip)
{
    for (int i = 0; skip && skip[i]; i++)
        if (strcmp(skip[i], name) == 0)
            return 1;
    return 0;
}

/* The index in rd_override_names of the flag a names ("--gamma" or
 * "--gamma=2"), or -1. */
static int override_of(const char *a, const char *const *skip)
{
    for (int i = 0; rd_override_names[i]; i++) {
        char flag[48];
        flag_of(rd_override_names[i], flag, sizeof flag);
        size_t n = strlen(flag);
        if (strncmp(a, flag, n) == 0 && (a[n] == 0 || a[n] == '=') && !skipped(rd_override_names[i], skip))
            return i;
    }
    return -1;
}

static int usage(const char *who, const char *msg)
{
    fprintf(stderr, "%s: %s\n", who, msg);
    return RD_EXIT_USAGE;
}

/* --set render.KEY=VALUE: the same check as the flag --KEY. */
static int take_set(const char *v, rd_scene_overrides *ov, const char *who, const char *const *skip)
{
    char key[48], what[80];
    const char *eq = v ? strchr(v, '=') : NULL;
    if (!v || strncmp(v, "render.", 7) != 0 || !eq || (size_t)(eq - v - 7) >= sizeof key)
        return usage(who, "--set: expected render.KEY=VALUE ('rayd render --help' lists the keys)");
    memcpy(key, v + 7, (size_t)(eq - v - 7));
    key[eq - v - 7] = 0;
    snprintf(what, sizeof what, "--set render.%s", key);
    rd_error err = {0};
    if (skipped(key, skip)) {
        snprintf(err.message, sizeof err.message, "%s: this command sets render.%s itself", what, key);
        return usage(who, err.message);
    }
    if (rd_override_set(ov, key, eq + 1, what, &err) == RD_ERR_NOT_FOUND) {
        char names[256] = "";
        size_t n = 0;
        for (int i = 0; rd_override_names[i] && n < sizeof names; i++)
            if (!skipped(rd_override_names[i], skip))
                n += (size_t)snprintf(names + n, sizeof names - n, "%s%s", n ? ", " : "", rd_override_names[i]);
        fprintf(stderr, "%s: %s (these can: %s)\n", who, err.message, names);
        return RD_EXIT_USAGE;
    }
    return err.code ? usage(who, err.message) : 0;
}

int rd_cli_take_overrides(int *argc, char **argv, rd_scene_overrides *ov, const char *who, const char *const *skip)
{
    int out = 0;
    for (int i = 0; i < *argc; i++) {
        const char *a = argv[i];
        int set = strcmp(a, "--set") == 0 || strncmp(a, "--set=", 6) == 0;
        int k = set || strncmp(a, "--", 2) != 0 ? -1 : override_of(a, skip);
        if (!set && k < 0) {
            argv[out++] = argv[i];
            continue;
        }
        const char *eq = strchr(a, '=');
        const char *value = eq ? eq + 1 : i + 1 < *argc ? argv[++i] : NULL;
        int rc;
        if (set) {
            rc = take_set(value, ov, who, skip);
        } else {
            char flag[48];
            flag_of(rd_override_names[k], flag, sizeof flag);
            rd_error err = {0};
            rc = !value ? usage(who, "an override needs a value")
                 : rd_override_set(ov, rd_override_names[k], value, flag, &err) ? usage(who, err.message)
                                                                                : 0;
        }
        if (rc)
            return rc;
    }
    argv[out] = NULL;
    *argc = out;
    return 0;
}

/* What a key takes, as the help says it: "an integer in 1..16384". */
static void takes(const rd_key *k, char *out, size_t size)
{
    char range[64];
    if (k->type == RD_KT_INT) {
        snprintf(out, size, "an integer in %.0f..%.0f", k->lo, k->hi);
    } else if (k->type == RD_KT_SEED) {
        snprintf(out, size, "an integer in 0..2^64-1");
    } else {
        rd_key_range_text(k, range, sizeof range);
        snprintf(out, size, "a number%s", range);
    }
}

void rd_cli_overrides_help(FILE *f, const char *const *skip)
{
    fputs("Render overrides (the query parameters of POST /v1/render; each replaces the\n"
          "scene's [render] key and takes exactly the values that key takes):\n",
          f);
    for (int i = 0; rd_override_names[i]; i++) {
        if (skipped(rd_override_names[i], skip))
            continue;
        const rd_key *k = rd_key_find(RD_SEC_RENDER, rd_override_names[i], strlen(rd_override_names[i]));
        char flag[48], what[96];
        flag_of(rd_override_names[i], flag, sizeof flag);
        takes(k, what, sizeof what);
        strcat(flag, " N");
        fprintf(f, "      %-20s render.%s: %s\n", flag, rd_override_names[i], what);
    }
    fputs("      --set render.KEY=VALUE  the same by the scene key's name (repeatable)\n", f);
}
