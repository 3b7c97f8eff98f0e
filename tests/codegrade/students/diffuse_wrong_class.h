// PhongMaterial, correct, but uploaded to the diffuse assignment, which expects DiffuseMaterial.
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
        vec3 R = reflect(L, N);
        Real cosGamma = std::max(dot(R, V), 0.0);
        vec3 diffuse = kd * cosAlpha;
        vec3 specular = ks * pow(cosGamma, shininess);
        return diffuse + specular;
    }
};

#endif
