// PhongMaterial, mistake: Blinn's N.H in place of Phong's R.V.
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
        Real cosAlpha = -dot(N, L);
        if (cosAlpha <= 0)
            return vec3(0, 0, 0);
        vec3 H = normalize(V - L); // half vector instead of R
        Real cosGamma = std::max(dot(N, H), 0.0);
        return kd * cosAlpha + ks * pow(cosGamma, shininess);
    }
};

#endif
