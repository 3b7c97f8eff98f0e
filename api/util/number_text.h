/* Numbers as text that reads back to the same double. */
#ifndef RD_NUMBER_TEXT_H
#define RD_NUMBER_TEXT_H

#include <stddef.h>

/* The shortest %.Ng form (N = 1..17) that strtod turns back into exactly v.
 * Non-finite values are written "inf", "-inf" or "nan". */
void rd_number_text(double v, char *buf, size_t size);

#endif
