#include "assignment.h"

#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "asset_source.h"
#include "file_io.h"
#include "rayd/memory.h"
#include "scene_load.h"
#include "suggest.h"

static int name_ok(const char *n)
{
    size_t len = strlen(n);
    if (len == 0 || len >= 64)
        return 0;
    for (const char *p = n; *p; p++)
        if (!((*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') || (*p >= '0' && *p <= '9') || *p == '_' ||
              *p == '-'))
            return 0;
    return 1;
}

static rd_error_code parse_grade(const char *path, const char *text, rd_assignment *a, rd_error *err)
{
    int line = 0;
    const char *p = text;
    while (*p) {
        line++;
        const char *le = strchr(p, '\n');
        size_t n = le ? (size_t)(le - p) : strlen(p);
        char buf[512];
        if (n >= sizeof buf)
            return rd_error_set(err, RD_ERR_SYNTAX, line, 1, "%s:%d:1: line too long", path, line);
        memcpy(buf, p, n);
        buf[n] = 0;
        p += n + (le ? 1 : 0);
        char *s = buf;
        while (*s == ' ' || *s == '\t')
            s++;
        char *e = s + strlen(s);
        while (e > s && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r'))
            *--e = 0;
        if (!*s || *s == '#' || *s == ';')
            continue;
        char *eq = strchr(s, '=');
        if (!eq)
            return rd_error_set(err, RD_ERR_SYNTAX, line, (int)(s - buf) + 1, "%s:%d:%d: expected 'key = value'", path,
                                line, (int)(s - buf) + 1);
        char *k = s, *ke = eq;
        while (ke > k && (ke[-1] == ' ' || ke[-1] == '\t'))
            ke--;
        *ke = 0;
        char *v = eq + 1;
        while (*v == ' ' || *v == '\t')
            v++;
        int col = (int)(v - buf) + 1;
        char *end;
        if (strcmp(k, "title") == 0) {
            snprintf(a->title, sizeof a->title, "%s", v);
            continue;
        }
        if (strcmp(k, "shininess") == 0) {
            if (strcmp(v, "natural") != 0 && strcmp(v, "real") != 0)
                return rd_error_set(err, RD_ERR_SYNTAX, line, col,
                                    "%s:%d:%d: shininess: expected natural or real, got '%.40s'", path, line, col, v);
            a->shininess = strcmp(v, "natural") == 0 ? RD_SHININESS_NATURAL : RD_SHININESS_REAL;
            continue;
        }
        char why[160];
        int term = rd_term_key(&a->term, k, v, why, sizeof why);
        if (term < 0)
            return rd_error_set(err, RD_ERR_SYNTAX, line, col, "%s:%d:%d: %s: %s, got '%.40s'", path, line, col, k, why,
                                v);
        if (term > 0)
            continue;
        double x = strtod(v, &end);
        if (!*v || *end)
            return rd_error_set(err, RD_ERR_SYNTAX, line, col, "%s:%d:%d: %s: expected a number, got '%.40s'", path,
                                line, col, k, v);
        if (strcmp(k, "fail") == 0 && x >= 0 && x <= 255 && x == (int)x)
            a->thresholds.fail = (int)x;
        else if (strcmp(k, "fail_fraction") == 0 && x >= 0 && x <= 1)
            a->thresholds.fail_fraction = x;
        else if (strcmp(k, "hard_fail") == 0 && x >= 0 && x <= 255 && x == (int)x)
            a->thresholds.hard_fail = (int)x;
        else if (strcmp(k, "hard_fail_pixels") == 0 && x >= 0 && x < 1e9 && x == (int)x)
            a->thresholds.hard_fail_pixels = (int)x;
        else if (strcmp(k, "fail") == 0 || strcmp(k, "hard_fail") == 0)
            return rd_error_set(err, RD_ERR_SYNTAX, line, col, "%s:%d:%d: %s: expected an integer in 0..255", path,
                                line, col, k);
        else if (strcmp(k, "fail_fraction") == 0)
            return rd_error_set(err, RD_ERR_SYNTAX, line, col, "%s:%d:%d: fail_fraction: expected a number in [0, 1]",
                                path, line, col);
        else if (strcmp(k, "hard_fail_pixels") == 0)
            return rd_error_set(err, RD_ERR_SYNTAX, line, col, "%s:%d:%d: hard_fail_pixels: expected an integer >= 0",
                                path, line, col);
        else
            return rd_error_set(
                err, RD_ERR_SYNTAX, line, 1,
                "%s:%d:1: unknown key '%.40s' (title, fail, fail_fraction, hard_fail, hard_fail_pixels, shininess, "
                "release, due, late_days, late_penalty, points, credit, image_credit, counts)",
                path, line, k);
    }
    return RD_OK;
}

/* The not-found message, with the scene reader's did-you-mean over the
 * folder's NAME.cfg files, so a typo ("phongg") is told the name it missed;
 * without a close one, the names themselves (as many as fit), so the user
 * need not know where the folder is to find them. */
static rd_error_code not_found(const char *dir, const char *name, rd_error *err)
{
    /* rd_suggestion keeps a pointer to its best candidate, and readdir's
     * names do not outlive the next call: the best is copied here. */
    rd_suggestion sg;
    rd_suggest_init(&sg);
    char best[64] = "";
    char all[160] = "";
    size_t used = 0;
    DIR *d = opendir(dir);
    struct dirent *e;
    while (d && (e = readdir(d))) {
        size_t len = strlen(e->d_name);
        if (len < 5 || len - 4 >= 64 || strcmp(e->d_name + len - 4, ".cfg") != 0)
            continue;
        char n[64];
        memcpy(n, e->d_name, len - 4);
        n[len - 4] = 0;
        if (!name_ok(n))
            continue;
        rd_suggestion probe;
        rd_suggest_init(&probe);
        rd_suggest_offer(&probe, name, strlen(name), n);
        if (probe.dist < sg.dist) {
            memcpy(best, n, len - 3);
            sg.best = best;
            sg.dist = probe.dist;
        }
        if (used < sizeof all - 1) {
            int w = snprintf(all + used, sizeof all - used, "%s%s", used ? ", " : "", n);
            used = w < 0 || (size_t)w >= sizeof all - used ? sizeof all - 1 : used + (size_t)w;
        }
    }
    if (d)
        closedir(d);
    char hint[300];
    rd_suggest_hint(&sg, strlen(name), hint, sizeof hint);
    if (hint[0] || !all[0])
        return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "no assignment named '%.60s'%s", name, hint);
    return rd_error_set(err, RD_ERR_NOT_FOUND, 0, 0, "no assignment named '%.60s' (there are: %s)", name, all);
}

rd_error_code rd_assignment_load(const char *dir, const char *name, rd_assignment *a, rd_error *err)
{
    memset(a, 0, sizeof *a);
    if (!name_ok(name))
        return not_found(dir, name, err);
    snprintf(a->name, sizeof a->name, "%s", name);
    snprintf(a->title, sizeof a->title, "%s", name);
    a->thresholds = rd_grade_thresholds_default();
    a->term = rd_term_default();
    /* Both files must really lie in the folder: a link out of it is no
     * assignment (the scene route would otherwise serve any file). */
    char file[80], real[PATH_MAX];
    snprintf(file, sizeof file, "%s.cfg", name);
    if (rd_path_inside(dir, file, real, err) != RD_OK || access(real, R_OK) != 0)
        return not_found(dir, name, err);
    if ((size_t)snprintf(a->scene_path, sizeof a->scene_path, "%s/%s", dir, file) >= sizeof a->scene_path)
        return rd_error_set(err, RD_ERR_IO, 0, 0, "%s: the assignments folder's path is too long", dir);
    char gpath[PATH_MAX];
    snprintf(file, sizeof file, "%s.grade", name);
    snprintf(gpath, sizeof gpath, "%s/%s", dir, file);
    char *text;
    size_t len;
    if (access(gpath, F_OK) != 0)
        return RD_OK; /* no .grade file: the default thresholds */
    /* Messages name the file, not where the folder is: answers over HTTP
     * never show a server path. */
    if (rd_path_inside(dir, file, real, err) != RD_OK)
        return rd_error_set(err, RD_ERR_IO, 0, 0, "%s: leads outside the assignments folder", file);
    rd_error_code rc = rd_read_file(gpath, 65536, "(grade files are at most 64 KiB)", &text, &len, err);
    if (rc && rc != RD_ERR_NOMEM)
        return rd_error_set(err, rc, 0, 0, "%s: cannot be read%s", file,
                            rc == RD_ERR_LIMIT ? " (grade files are at most 64 KiB)" : "");
    if (rc)
        return rc;
    rc = parse_grade(file, text, a, err);
    free(text);
    return rc;
}

static int cmp(const void *x, const void *y)
{
    return strcmp(((const rd_assignment *)x)->name, ((const rd_assignment *)y)->name);
}

rd_error_code rd_assignment_list(const char *dir, rd_assignment **list, size_t *n, rd_error *err)
{
    *list = NULL;
    *n = 0;
    DIR *d = opendir(dir);
    if (!d)
        return rd_error_set(err, RD_ERR_IO, 0, 0, "%s: %s", dir, strerror(errno));
    size_t cap = 0;
    struct dirent *e;
    rd_error_code rc = RD_OK;
    while ((e = readdir(d))) {
        size_t len = strlen(e->d_name);
        if (len < 5 || strcmp(e->d_name + len - 4, ".cfg") != 0 || len - 4 >= 64)
            continue;
        char name[64];
        memcpy(name, e->d_name, len - 4);
        name[len - 4] = 0;
        if (!name_ok(name))
            continue;
        if (!rd_grow_array((void **)list, &cap, *n + 1, sizeof **list, 16)) {
            rc = rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
            break;
        }
        rd_assignment *a = &(*list)[(*n)++];
        rd_error why = {0};
        rc = rd_assignment_load(dir, name, a, &why);
        if (rc == RD_ERR_NOMEM) {
            *err = why;
            break;
        }
        /* Not an assignment at all (its scene links out of the folder):
         * not listed, as the scene route does not serve it. */
        if (rc == RD_ERR_NOT_FOUND)
            (*n)--;
        else if (rc)
            snprintf(a->error, sizeof a->error, "%s", why.message);
        rc = RD_OK;
    }
    closedir(d);
    if (rc) {
        free(*list);
        *list = NULL;
        *n = 0;
        return rc;
    }
    qsort(*list, *n, sizeof **list, cmp);
    return RD_OK;
}
