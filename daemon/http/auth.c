#include "auth.h"

#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "file_io.h"

enum { FILE_MAX = 64 * 1024, TOKENS_MAX = 1024, TOKEN_MIN = 16, TOKEN_MAX = 256 };

struct rd_auth {
    int n;
    char tokens[][TOKEN_MAX + 1];
};

static int token_char(unsigned char c) { return c > ' ' && c < 127; }

/* One line of the file: 1 a token (copied to out), 0 nothing, -1 bad. */
static int read_line(const char *line, size_t len, char *out)
{
    while (len && (line[len - 1] == '\r' || line[len - 1] == ' ' || line[len - 1] == '\t'))
        len--;
    while (len && (*line == ' ' || *line == '\t')) {
        line++;
        len--;
    }
    if (len == 0 || *line == '#')
        return 0;
    if (len < TOKEN_MIN || len > TOKEN_MAX)
        return -1;
    for (size_t i = 0; i < len; i++)
        if (!token_char((unsigned char)line[i]))
            return -1;
    memcpy(out, line, len);
    out[len] = 0;
    return 1;
}

rd_auth *rd_auth_load(const char *path, rd_error *err)
{
    char *text;
    size_t len;
    if (rd_read_file(path, FILE_MAX, "--instructor-tokens", &text, &len, err))
        return NULL;
    rd_auth *a = calloc(1, sizeof *a + TOKENS_MAX * sizeof a->tokens[0]);
    if (!a) {
        free(text);
        rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
        return NULL;
    }
    int line = 1, bad = 0;
    for (const char *p = text; p < text + len && !bad; line++) {
        const char *nl = memchr(p, '\n', (size_t)(text + len - p));
        size_t n = nl ? (size_t)(nl - p) : (size_t)(text + len - p);
        int r = a->n < TOKENS_MAX ? read_line(p, n, a->tokens[a->n]) : -1;
        if (r < 0)
            bad = line;
        a->n += r > 0;
        p += n + 1;
    }
    free(text);
    if (bad || a->n == 0) {
        if (bad)
            rd_error_set(err, RD_ERR_INVALID, bad, 1,
                         "%s:%d: a token is %d to %d printable characters without spaces (at most %d tokens)", path,
                         bad, TOKEN_MIN, TOKEN_MAX, TOKENS_MAX);
        else
            rd_error_set(err, RD_ERR_INVALID, 0, 0, "%s holds no token (--instructor-tokens)", path);
        free(a);
        return NULL;
    }
    return a;
}

void rd_auth_free(rd_auth *a) { free(a); }

int rd_auth_count(const rd_auth *a) { return a->n; }

/* 0 when equal. Reads all of want (its length is the file's, not the
 * request's), and got up to want's length plus its own end. */
static unsigned differ(const char *want, const char *got, size_t got_len)
{
    size_t want_len = strlen(want);
    unsigned d = (unsigned)(want_len ^ got_len);
    for (size_t i = 0; i < want_len; i++) {
        unsigned char g = i < got_len ? (unsigned char)got[i] : 0;
        d |= (unsigned)((unsigned char)want[i] ^ g);
    }
    return d;
}

rd_auth_result rd_auth_check(const rd_auth *a, const char *authorization)
{
    if (!authorization || strncasecmp(authorization, "Bearer ", 7) != 0)
        return RD_AUTH_MISSING;
    const char *tok = authorization + 7;
    while (*tok == ' ')
        tok++;
    size_t len = strlen(tok);
    while (len && tok[len - 1] == ' ')
        len--;
    if (len == 0)
        return RD_AUTH_MISSING;
    unsigned match = 0;
    for (int i = 0; i < a->n; i++)
        match |= differ(a->tokens[i], tok, len) == 0;
    return match ? RD_AUTH_OK : RD_AUTH_WRONG;
}
