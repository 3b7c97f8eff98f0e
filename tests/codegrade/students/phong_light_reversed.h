// PhongMaterial, mistake: treats incomingDir as pointing to the light (cos(alpha) = N.L, R = 2(N.L)N - L).
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
        // L points to the light
        Real cosAlpha = dot(N, L);
        if (cosAlpha <= 0)
            return vec3(0, 0, 0);
        vec3 R = 2 * cosAlpha * N - L;
        Real cosGamma = std::max(dot(R, V), 0.0);
        return kd * cosAlpha + ks * pow(cosGamma, shininess);
    }
};

#endif
