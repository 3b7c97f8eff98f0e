/* Things a scene author should hear about that do not stop the render
 * (an OBJ face with a degenerate normal, a texture's odd layout). */
#ifndef RD_WARNINGS_H
#define RD_WARNINGS_H

typedef struct {
    int count;       /* all of them */
    char text[1024]; /* the first five, one per line */
} rd_warnings;

/* Adds one; w may be NULL (nobody listens). */
void rd_warn(rd_warnings *w, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#endif
