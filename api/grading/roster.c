#include "roster.h"

#include <stdlib.h>
#include <string.h>

#include "file_io.h"
#include "rayd/memory.h"
#include "utf8.h"

/* A reader of one CSV record at a time. */
typedef struct {
    const char *text, *p, *end, *source;
    int line, col; /* where p is */
} csv;

enum { CELLS_MAX = 64 };

typedef struct {
    char cell[CELLS_MAX][RD_ROSTER_CELL_MAX + 1];
    int col[CELLS_MAX]; /* each cell's column, for messages */
    int n, line;
} record;

static rd_error_code fault(const csv *c, int line, int col, rd_error *err, const char *what)
{
    return rd_error_set(err, RD_ERR_SYNTAX, line, col, "%s:%d:%d: %s", c->source, line, col, what);
}

static void advance(csv *c)
{
    c->col += ((unsigned char)*c->p & 0xC0) != 0x80;
    c->p++;
}

/* One byte into cell k at *len. */
static rd_error_code put(csv *c, record *r, size_t *len, rd_error *err)
{
    if (*len == RD_ROSTER_CELL_MAX)
        return fault(c, c->line, r->col[r->n], err, "a cell is longer than 255 bytes");
    r->cell[r->n][(*len)++] = *c->p;
    advance(c);
    return RD_OK;
}

/* A quoted cell's body, the opening quote read. */
static rd_error_code quoted(csv *c, record *r, size_t *len, rd_error *err)
{
    int line = c->line, col = c->col - 1;
    for (;;) {
        if (c->p == c->end)
            return fault(c, line, col, err, "a quoted cell is not closed");
        if (*c->p == '"' && c->p + 1 < c->end && c->p[1] == '"') {
            advance(c);
        } else if (*c->p == '"') {
            advance(c);
            return RD_OK;
        } else if (*c->p == '\n') {
            c->line++;
            c->col = 0;
        }
        rd_error_code rc = put(c, r, len, err);
        if (rc)
            return rc;
    }
}

/* One cell, up to its separator, line end or the end. */
static rd_error_code cell(csv *c, record *r, rd_error *err)
{
    if (r->n == CELLS_MAX)
        return fault(c, c->line, c->col, err, "more than 64 columns");
    r->col[r->n] = c->col;
    size_t len = 0;
    rd_error_code rc = RD_OK;
    if (c->p < c->end && *c->p == '"') {
        advance(c);
        rc = quoted(c, r, &len, err);
        if (!rc && c->p < c->end && !strchr(",\r\n", *c->p))
            rc = fault(c, c->line, c->col, err, "text after a quoted cell's closing quote");
    }
    while (!rc && c->p < c->end && !strchr(",\r\n", *c->p))
        rc = *c->p == '"' ? fault(c, c->line, c->col, err, "a quote inside an unquoted cell") : put(c, r, &len, err);
    if (rc)
        return rc;
    r->cell[r->n][len] = 0;
    if (rd_utf8_invalid_at(r->cell[r->n], len) != len)
        return fault(c, r->line, r->col[r->n], err, "a cell is not UTF-8 text");
    r->n++;
    return RD_OK;
}

/* The next record into r; 0 at the end. */
static int next_record(csv *c, record *r, rd_error_code *rc, rd_error *err)
{
    while (c->p < c->end && (*c->p == '\n' || *c->p == '\r')) {
        if (*c->p == '\n')
            c->line++, c->col = 0;
        advance(c);
    }
    if (c->p == c->end)
        return 0;
    r->n = 0;
    r->line = c->line;
    for (;;) {
        if ((*rc = cell(c, r, err)))
            return 1;
        if (c->p == c->end || *c->p != ',')
            return 1;
        advance(c);
    }
}

/* The header's columns: which cell is student, name, email (-1: none). */
static rd_error_code header(csv *c, const record *h, int at[3], rd_error *err)
{
    static const char *const names[] = {"student", "name", "email"};
    at[0] = at[1] = at[2] = -1;
    for (int i = 0; i < h->n; i++)
        for (int k = 0; k < 3; k++)
            if (strcmp(h->cell[i], names[k]) == 0)
                at[k] = i;
    return at[0] < 0 ? fault(c, h->line, 1, err, "the first line names no 'student' column (student,name,email)")
                     : RD_OK;
}

static char *dup_cell(const record *r, int i) { return strdup(i >= 0 && i < r->n ? r->cell[i] : ""); }

static rd_error_code add(csv *c, rd_roster *out, size_t *cap, const record *r, const int at[3], rd_error *err)
{
    if (at[0] >= r->n || !r->cell[at[0]][0])
        return fault(c, r->line, at[0] < r->n ? r->col[at[0]] : 1, err, "a line without a student id");
    if (out->n == RD_ROSTER_MAX_STUDENTS)
        return rd_error_set(err, RD_ERR_LIMIT, r->line, 1, "%s:%d:1: more than %d students", c->source, r->line,
                            RD_ROSTER_MAX_STUDENTS);
    if (!rd_grow_array((void **)&out->e, cap, out->n + 1, sizeof *out->e, 64))
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    rd_roster_entry *e = &out->e[out->n];
    *e = (rd_roster_entry){dup_cell(r, at[0]), dup_cell(r, at[1]), dup_cell(r, at[2])};
    out->n++;
    return e->student && e->name && e->email ? RD_OK : rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
}

static int by_student(const void *a, const void *b)
{
    return strcmp(((const rd_roster_entry *)a)->student, ((const rd_roster_entry *)b)->student);
}

/* Sorted, no student twice. */
static rd_error_code sort_unique(const char *source, rd_roster *out, rd_error *err)
{
    /* A roster of no student (a header alone) has no array to sort. */
    if (out->n > 1)
        qsort(out->e, out->n, sizeof *out->e, by_student);
    for (size_t i = 1; i < out->n; i++)
        if (strcmp(out->e[i - 1].student, out->e[i].student) == 0)
            return rd_error_set(err, RD_ERR_SYNTAX, 0, 0, "%s: student '%.60s' is listed twice", source,
                                out->e[i].student);
    return RD_OK;
}

rd_error_code rd_roster_parse(const char *text, size_t len, const char *source, rd_roster *out, rd_error *err)
{
    memset(out, 0, sizeof *out);
    size_t bom = rd_utf8_bom(text, len);
    csv c = {text, text + bom, text + len, source ? source : "roster", 1, 1};
    record *r = malloc(sizeof *r);
    if (!r)
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    int at[3];
    size_t cap = 0;
    rd_error_code rc = RD_OK;
    if (!next_record(&c, r, &rc, err))
        rc = rd_error_set(err, RD_ERR_SYNTAX, 1, 1, "%s:1:1: the roster is empty (a line student,name,email first)",
                          c.source);
    else if (!rc)
        rc = header(&c, r, at, err);
    while (!rc && next_record(&c, r, &rc, err))
        if (!rc)
            rc = add(&c, out, &cap, r, at, err);
    free(r);
    if (!rc)
        rc = sort_unique(c.source, out, err);
    if (rc)
        rd_roster_free(out);
    return rc;
}

rd_error_code rd_roster_load(const char *path, rd_roster *out, rd_error *err)
{
    memset(out, 0, sizeof *out);
    char *text;
    size_t len;
    rd_error_code rc = rd_read_file(path, RD_ROSTER_MAX_BYTES, "(a roster is at most 80 MB)", &text, &len, err);
    if (rc)
        return rc;
    rc = rd_roster_parse(text, len, path, out, err);
    free(text);
    return rc;
}

const rd_roster_entry *rd_roster_find(const rd_roster *r, const char *student)
{
    rd_roster_entry key = {(char *)student, NULL, NULL};
    return r->n ? bsearch(&key, r->e, r->n, sizeof *r->e, by_student) : NULL;
}

void rd_roster_free(rd_roster *r)
{
    for (size_t i = 0; r->e && i < r->n; i++) {
        free(r->e[i].student);
        free(r->e[i].name);
        free(r->e[i].email);
    }
    free(r->e);
    r->e = NULL;
    r->n = 0;
}
