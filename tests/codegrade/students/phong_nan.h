// PhongMaterial, mistake: H = normalize(L + V), a zero vector normalized (NaN) when L = -V (light at the eye).
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
        Real cosAlpha = std::max(-dot(N, L), 0.0);
        // the direction halfway between the light and the eye
        vec3 H = normalize(L + V);
        Real cosGamma = std::max(dot(N, H), 0.0);
        return kd * cosAlpha + ks * pow(cosGamma, shininess);
    }
};

#endif
