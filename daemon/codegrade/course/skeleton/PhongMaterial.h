/* PhongMaterial: diffuse plus Phong's glossy reflection. Fill in calcReflectedLight. */
#ifndef PHONGMATERIAL_H
#define PHONGMATERIAL_H

#include "Material.h"

class PhongMaterial : public Material
{
  public:
    Real shininess; // n of cos^n(gamma)
    vec3 ks;        // specular reflectance k_s, per RGB channel
    vec3 kd;        // diffuse reflectance k_d, per RGB channel

    PhongMaterial() : shininess(1), ks(0), kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
    {
        // Fill in: return I_d + I_s, equation (8) without the ambient term I_a:
        //   I_d = k_d max{cos(alpha), 0}               (equation (2))
        //   I_s = k_s cos^n(gamma), n = shininess      (equation (7))
        // record.normal is N, the unit surface normal.
        // incomingDir is L, a unit vector pointing FROM the light TO the surface,
        // so cos(alpha) = -(N . L). When it is not positive the light is behind the
        // surface and nothing is reflected: return black.
        // outgoingDir is V, a unit vector pointing away from the surface (toward the viewer).
        // R = reflect(incomingDir, record.normal) is the mirror direction of L, and
        // cos(gamma) = R . V; exclude the cases where cos(gamma) is negative.
        // pow(x, y) computes x^y. Compute each of R, G and B (as in equations (3)-(5)).
        // Do not add ambient (the tracer adds getAmbientCoeff()) and do not multiply
        // by the light's colour I_in (the tracer does, with mult()).
        return vec3(0, 0, 0);
    }
};

#endif
