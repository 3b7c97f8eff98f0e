/* CookTorranceMaterial: diffuse plus the Cook-Torrance microfacet model.
 * calcReflectedLight is only declared: a .cpp that includes this file
 * defines vec3 CookTorranceMaterial::calcReflectedLight(...). */
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

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir);
};

#endif
