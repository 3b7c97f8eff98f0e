#include "number_text.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

void rd_number_text(double v, char *buf, size_t size)
{
    if (!isfinite(v)) {
        snprintf(buf, size, "%s", isnan(v) ? "nan" : (v > 0 ? "inf" : "-inf"));
        return;
    }
    /* Whole numbers as integers: 640, not 6.4e+02. */
    if (v == floor(v) && fabs(v) <= 9007199254740992.0) { /* 2^53: every integer exact */
        snprintf(buf, size, "%.0f", v);
        if (v == 0 && signbit(v))
            snprintf(buf, size, "-0");
        return;
    }
    for (int p = 1; p <= 17; p++) {
        snprintf(buf, size, "%.*g", p, v);
        if (strtod(buf, NULL) == v)
            return;
    }
}
