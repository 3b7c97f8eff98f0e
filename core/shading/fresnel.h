/* Reflection and refraction at a smooth dielectric boundary. */
#ifndef RD_FRESNEL_H
#define RD_FRESNEL_H

/* Exact unpolarised Fresnel reflectance for light going from index n1 into
 * n2 at incidence cosine cosi (clamped to [0, 1]): the mean of the s and p
 * reflectances. Returns 1 under total internal reflection. *cost gets the
 * transmitted cosine (0 under total internal reflection). Result in [0, 1];
 * 1 - R is the transmitted fraction. */
double rd_fresnel_dielectric(double cosi, double n1, double n2, double *cost);

#endif
