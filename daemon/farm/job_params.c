#include "job_params.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const own_names[] = {"time_budget_ms", "target_error", "adaptive", "hdr", NULL};

const char *rd_job_param_name(int i)
{
    int n = 0;
    while (rd_override_names[n])
        n++;
    return i < n ? rd_override_names[i] : own_names[i - n < 4 ? i - n : 4];
}

void rd_job_params_init(rd_job_params *p) { memset(p, 0, sizeof *p); }

static rd_error_code positive(const char *name, const char *v, double *out, rd_error *err)
{
    char *end;
    double x = strtod(v, &end);
    if (!*v || *end || !(x > 0) || !(x < 1e15))
        return rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "query parameter %s: expected a number > 0, got '%.40s'", name,
                            v);
    *out = x;
    return RD_OK;
}

static rd_error_code flag(const char *name, const char *v, int *out, rd_error *err)
{
    if (strcmp(v, "1") == 0 || strcmp(v, "true") == 0)
        *out = 1;
    else if (strcmp(v, "0") == 0 || strcmp(v, "false") == 0)
        *out = 0;
    else
        return rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "query parameter %s: expected 0 or 1, got '%.40s'", name, v);
    return RD_OK;
}

static rd_error_code read_one(rd_job_params *p, const char *name, const char *v, rd_error *err)
{
    if (strcmp(name, "time_budget_ms") == 0)
        return positive(name, v, &p->progress.time_budget_ms, err);
    if (strcmp(name, "target_error") == 0)
        return positive(name, v, &p->progress.target_error, err);
    if (strcmp(name, "adaptive") == 0)
        return flag(name, v, &p->progress.adaptive, err);
    if (strcmp(name, "hdr") == 0) {
        int on = 0;
        rd_error_code rc = flag(name, v, &on, err);
        p->hdr |= on;
        return rc;
    }
    char what[48];
    snprintf(what, sizeof what, "query parameter %s", name);
    return rd_override_set(&p->ov, name, v, what, err);
}

/* A value goes into the text only once read, so the text holds nothing a
 * reader refuses; '&' and '=' cannot be in a value that was accepted, and
 * a text that would not fit is refused rather than cut. */
rd_error_code rd_job_params_set(rd_job_params *p, const char *name, const char *value, rd_error *err)
{
    if (!name || !value)
        return rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "query parameter %s: no value", name ? name : "?");
    rd_error_code rc = read_one(p, name, value, err);
    if (rc)
        return rc;
    if (strpbrk(value, "&="))
        return rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "query parameter %s: '&' or '=' in its value", name);
    size_t used = strlen(p->query), need = strlen(name) + strlen(value) + 2;
    if (used + need >= sizeof p->query)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "the query parameters are longer than %zu bytes",
                            sizeof p->query - 1);
    snprintf(p->query + used, sizeof p->query - used, "%s%s=%s", used ? "&" : "", name, value);
    return RD_OK;
}

rd_error_code rd_job_params_parse(rd_job_params *p, const char *query, rd_error *err)
{
    rd_job_params_init(p);
    if (!query || !*query)
        return RD_OK;
    char buf[sizeof p->query];
    if (strlen(query) >= sizeof buf)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "the query parameters are longer than %zu bytes", sizeof buf - 1);
    strcpy(buf, query);
    char *save = NULL;
    for (char *item = strtok_r(buf, "&", &save); item; item = strtok_r(NULL, "&", &save)) {
        char *eq = strchr(item, '=');
        if (!eq)
            return rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "query parameter %.40s: no value", item);
        *eq = 0;
        rd_error_code rc = rd_job_params_set(p, item, eq + 1, err);
        if (rc)
            return rc;
    }
    return RD_OK;
}
