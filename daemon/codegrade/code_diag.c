/* The compiler's messages as a student reads them: the sandbox's folders
 * left out of every path, and each "file:line:column: severity: text"
 * line also as a structured diagnostic. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "codegrade.h"
#include "strbuf.h"

/* Where the sandbox keeps files; a student knows only the names. */
static const char *const hidden[] = {"/work/", "/rayd/course/decl/", "/rayd/course/", "/tmp/"};

/* The raw text is not NUL-terminated: only the left bytes are compared. */
static size_t hidden_prefix(const char *p, size_t left)
{
    for (size_t i = 0; i < sizeof hidden / sizeof *hidden; i++) {
        size_t n = strlen(hidden[i]);
        if (n <= left && memcmp(p, hidden[i], n) == 0)
            return n;
    }
    return 0;
}

static char *shorten(const char *raw, size_t len)
{
    rd_strbuf b = {0};
    for (size_t i = 0; i < len;) {
        size_t skip = hidden_prefix(raw + i, len - i);
        if (skip) {
            i += skip;
            continue;
        }
        /* control bytes but newline and tab would garble a page or a terminal */
        char c = raw[i] == '\n' || raw[i] == '\t' || (unsigned char)raw[i] >= 0x20 ? raw[i] : '?';
        rd_strbuf_append(&b, &c, 1);
        i++;
    }
    return rd_strbuf_take(&b, NULL);
}

static const char *const severities[] = {"fatal error", "error", "warning", "note"};

/* "file:line:column: severity: message" */
static int parse_line(const char *line, size_t len, rd_code_diag *d)
{
    const char *end = line + len, *c1 = memchr(line, ':', len);
    if (!c1 || c1 == line || (size_t)(c1 - line) >= sizeof d->file)
        return 0;
    char *after;
    long ln = strtol(c1 + 1, &after, 10);
    if (after == c1 + 1 || *after != ':' || ln <= 0)
        return 0;
    long col = strtol(after + 1, &after, 10);
    if (*after != ':' || col <= 0 || after + 2 > end || after[1] != ' ')
        return 0;
    const char *sev = after + 2;
    for (size_t i = 0; i < sizeof severities / sizeof *severities; i++) {
        size_t n = strlen(severities[i]);
        if ((size_t)(end - sev) > n + 1 && strncmp(sev, severities[i], n) == 0 && sev[n] == ':') {
            snprintf(d->file, sizeof d->file, "%.*s", (int)(c1 - line), line);
            d->line = (int)(ln < 1000000 ? ln : 1000000);
            d->column = (int)(col < 1000000 ? col : 1000000);
            snprintf(d->severity, sizeof d->severity, "%s", severities[i]);
            const char *m = sev + n + 1 + (sev[n + 1] == ' ');
            snprintf(d->message, sizeof d->message, "%.*s", (int)(end - m), m);
            return 1;
        }
    }
    return 0;
}

void rd_code_compile_messages(rd_code_compile *c, const char *raw, size_t len)
{
    c->messages = shorten(raw, len);
    c->diags = calloc(RD_CODE_MAX_DIAGS, sizeof *c->diags);
    c->ndiags = 0;
    if (!c->messages || !c->diags)
        return;
    for (const char *p = c->messages; *p && c->ndiags < RD_CODE_MAX_DIAGS;) {
        const char *nl = strchr(p, '\n');
        size_t n = nl ? (size_t)(nl - p) : strlen(p);
        if (parse_line(p, n, &c->diags[c->ndiags]))
            c->ndiags++;
        p += n + (nl != NULL);
    }
}
