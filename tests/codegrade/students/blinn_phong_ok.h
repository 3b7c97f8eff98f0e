// BlinnPhongMaterial, correct: k_d cos(alpha) + k_s max{N.H, 0}^n with H = normalize(V - L).
#ifndef BLINNPHONGMATERIAL_H
#define BLINNPHONGMATERIAL_H

#include "Material.h"

class BlinnPhongMaterial : public Material
{
  public:
    Real shininess; // n of cos^n
    vec3 ks;        // specular reflectance
    vec3 kd;        // diffuse reflectance

    BlinnPhongMaterial() : shininess(1), ks(0), kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
    {
        vec3 N = record.normal;
        vec3 L = incomingDir;
        vec3 V = outgoingDir;
        Real cosAlpha = -dot(N, L);
        if (cosAlpha <= 0)
            return vec3(0, 0, 0);
        vec3 H = normalize(V - L);
        Real cosHalf = std::max(dot(N, H), 0.0);
        return kd * cosAlpha + ks * pow(cosHalf, shininess);
    }
};

#endif
