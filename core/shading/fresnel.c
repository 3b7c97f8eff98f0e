#include "fresnel.h"

#include <math.h>

double rd_fresnel_dielectric(double cosi, double n1, double n2, double *cost_out)
{
    cosi = cosi < 0 ? 0 : (cosi > 1 ? 1 : cosi);
    if (n1 == n2) {
        /* No boundary: everything goes through, at any angle. */
        *cost_out = cosi;
        return 0;
    }
    double eta = n1 / n2;
    /* cos²θt = (1 - η²) + η² cos²θi. Near the critical angle it is a
     * difference of nearly equal terms: long double keeps the digits. */
    long double el = (long double)eta;
    double cos2t = (double)((1 - el * el) + el * el * (long double)cosi * (long double)cosi);
    if (!(cos2t > 0)) {
        *cost_out = 0;
        return 1;
    }
    double cost = sqrt(cos2t);
    *cost_out = cost;
    double rs = (n1 * cosi - n2 * cost) / (n1 * cosi + n2 * cost);
    double rp = (n1 * cost - n2 * cosi) / (n1 * cost + n2 * cosi);
    double F = 0.5 * (rs * rs + rp * rp);
    /* At grazing incidence both denominators vanish with the numerators. */
    if (!(F == F))
        return 1;
    return F > 1 ? 1 : (F < 0 ? 0 : F);
}
