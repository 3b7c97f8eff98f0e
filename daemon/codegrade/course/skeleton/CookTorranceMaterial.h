/* CookTorranceMaterial: diffuse plus the Cook-Torrance microfacet model.
 * Fill in calcReflectedLight. */
#ifndef COOKTORRANCEMATERIAL_H
#define COOKTORRANCEMATERIAL_H

#include "Material.h"

class CookTorranceMaterial : public Material
{
  public:
    Real roughness; // m, the RMS slope of the microfacets (Beckmann distribution)
    vec3 ks;        // Fresnel reflectance at normal incidence F_0, per RGB channel
    vec3 kd;        // diffuse reflectance k_d, per RGB channel

    CookTorranceMaterial() : roughness(0.3), ks(0), kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
    {
        // Fill in: return I_d + I_s as in equation (8) without the ambient term I_a:
        //   I_d = k_d max{cos(alpha), 0}               (equation (2))
        //   I_s = F D G / (4 (N . V))                  (the Cook-Torrance BRDF times cos(alpha))
        // record.normal is N, the unit surface normal.
        // incomingDir is L, a unit vector pointing FROM the light TO the surface,
        // so cos(alpha) = -(N . L). When it is not positive the light is behind the
        // surface and nothing is reflected: return black.
        // outgoingDir is V, a unit vector pointing away from the surface (toward the
        // viewer). When N . V is not positive, return I_d alone.
        // H = normalize(V - L), the half vector between -L and V.
        // D: Beckmann distribution, with theta the angle between N and H and m = roughness:
        //   D = exp(-tan^2(theta) / m^2) / (pi m^2 cos^4(theta))
        // G: geometric attenuation,
        //   G = min{1, 2 (N . H)(N . V) / (V . H), 2 (N . H) cos(alpha) / (V . H)}
        // F: Schlick's approximation per RGB channel, with ks as F_0:
        //   F = ks + (1 - ks) (1 - V . H)^5
        // Do not add ambient (the tracer adds getAmbientCoeff()) and do not multiply
        // by the light's colour I_in (the tracer does, with mult()).
        return vec3(0, 0, 0);
    }
};

#endif
