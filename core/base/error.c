#include "rayd/error.h"

#include <stdarg.h>
#include <stdio.h>

rd_error_code rd_error_set(rd_error *err, rd_error_code code, int line, int column, const char *fmt, ...)
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

const char *rd_error_name(rd_error_code code)
{
    static const char *const names[] = {
#define RD_ERROR_NAME(c, name, meaning) name,
        RD_ERRORS(RD_ERROR_NAME)
#undef RD_ERROR_NAME
    };
    return (unsigned)code < RD_ERROR_COUNT ? names[code] : "?";
}
