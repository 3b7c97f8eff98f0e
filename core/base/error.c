#include "rayd/error.h"

#include <stdarg.h>
#include <stdio.h>

rd_error_code rd_error_set(rd_error *err, rd_error_code code, int line, int column,
                           const char *fmt, ...)
{
    if (err) {
        err->code = code;
        err->line = line;
        err->column = column;
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
    }
    return code;
}
