#include "warnings.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

void rd_warn(rd_warnings *w, const char *fmt, ...)
{
    if (!w)
        return;
    w->count++;
    size_t used = strlen(w->text);
    if (w->count > 5 || used + 2 >= sizeof w->text)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(w->text + used, sizeof w->text - used - 1, fmt, ap);
    va_end(ap);
    used = strlen(w->text);
    w->text[used] = '\n';
    w->text[used + 1] = 0;
}
