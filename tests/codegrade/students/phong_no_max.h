// PhongMaterial, mistake: no max anywhere: neither cos(alpha) nor cos(gamma) clamped, no black for light from behind.
#ifndef PHONGMATERIAL_H
#define PHONGMATERIAL_H

#include "Material.h"

class PhongMaterial : public Material
{
  public:
    Real shininess; // n of cos^n
    vec3 ks;        // specular reflectance
    vec3 kd;        // diffuse reflectance

    PhongMaterial() : shininess(1), ks(0), kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
    {
        vec3 N = record.normal;
        vec3 L = incomingDir;
        vec3 V = outgoingDir;
        Real cosAlpha = -dot(N, L); // no max: negative behind the surface
        vec3 R = reflect(L, N);
        Real cosGamma = dot(R, V); // no max either
        return kd * cosAlpha + ks * pow(cosGamma, shininess);
    }
};

#endif
