/* BlinnPhongMaterial: diffuse plus Blinn's half-vector variant of Phong's
 * glossy reflection. Fill in calcReflectedLight. */
#ifndef BLINNPHONGMATERIAL_H
#define BLINNPHONGMATERIAL_H

#include "Material.h"

class BlinnPhongMaterial : public Material
{
  public:
    Real shininess; // n of cos^n
    vec3 ks;        // specular reflectance k_s, per RGB channel
    vec3 kd;        // diffuse reflectance k_d, per RGB channel

    BlinnPhongMaterial() : shininess(1), ks(0), kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
    {
        // Fill in: return I_d + I_s as in equation (8) without the ambient term I_a:
        //   I_d = k_d max{cos(alpha), 0}               (equation (2))
        //   I_s = k_s max{N . H, 0}^n, n = shininess   (equation (7) with N . H for cos(gamma))
        // record.normal is N, the unit surface normal.
        // incomingDir is L, a unit vector pointing FROM the light TO the surface,
        // so cos(alpha) = -(N . L). When it is not positive the light is behind the
        // surface and nothing is reflected: return black.
        // outgoingDir is V, a unit vector pointing away from the surface (toward the viewer).
        // H is the unit vector halfway between the direction to the light (-L) and V:
        // H = normalize(V - L).
        // Do not add ambient (the tracer adds getAmbientCoeff()) and do not multiply
        // by the light's colour I_in (the tracer does, with mult()).
        return vec3(0, 0, 0);
    }
};

#endif
