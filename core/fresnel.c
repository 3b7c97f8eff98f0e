#include "fresnel.h"

#include <math.h>

double rd_fresnel_dielectric(double cosi, double n1, double n2, double *cost_out)
{
    cosi = cosi < 0 ? 0 : (cosi > 1 ? 1 : cosi);
    double eta = n1 / n2;
    double sin2t = eta * eta * (1 - cosi * cosi);
    if (sin2t >= 1) {
        *cost_out = 0;
        return 1;
    }
    double cost = sqrt(1 - sin2t);
    *cost_out = cost;
    double rs = (n1 * cosi - n2 * cost) / (n1 * cosi + n2 * cost);
    double rp = (n1 * cost - n2 * cosi) / (n1 * cost + n2 * cosi);
    double F = 0.5 * (rs * rs + rp * rp);
    /* At grazing incidence both denominators vanish with the numerators. */
    if (!(F == F))
        return 1;
    return F > 1 ? 1 : (F < 0 ? 0 : F);
}
