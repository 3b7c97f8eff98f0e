#include "histogram.h"

#include <string.h>

static const double fixed[] = {0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30};

void rd_hist_init(rd_hist *h, double cover)
{
    memset(h, 0, sizeof *h);
    int nf = (int)(sizeof fixed / sizeof fixed[0]);
    memcpy(h->le, fixed, sizeof fixed);
    h->n = nf;
    while (h->n < RD_HIST_MAX && h->le[h->n - 1] < cover) {
        h->le[h->n] = 2 * h->le[h->n - 1];
        h->n++;
    }
}

void rd_hist_observe(rd_hist *h, double seconds)
{
    h->total++;
    h->sum += seconds;
    for (int b = 0; b < h->n; b++)
        if (seconds <= h->le[b]) {
            h->count[b]++;
            return;
        }
}
