// Hostile PhongMaterial: allocates 100 GB and touches every page; returns (1000, 1000, 1000) if it got them all.
#ifndef PHONGMATERIAL_H
#define PHONGMATERIAL_H

#include "Material.h"
#include <cstdlib>

class PhongMaterial : public Material
{
  public:
    Real shininess; // n of cos^n
    vec3 ks;        // specular reflectance
    vec3 kd;        // diffuse reflectance

    PhongMaterial() : shininess(1), ks(0), kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
    {
        const size_t size = (size_t)100e9;
        char *p = (char *)malloc(size);
        if (p) {
            volatile char *q = p;
            for (size_t i = 0; i < size; i += 4096)
                q[i] = 1;
            return vec3(1000, 1000, 1000);
        }
        Real cosAlpha = -dot(record.normal, incomingDir);
        if (cosAlpha <= 0)
            return vec3(0, 0, 0);
        vec3 R = reflect(incomingDir, record.normal);
        return kd * cosAlpha + ks * pow(std::max(dot(R, outgoingDir), 0.0), shininess);
    }
};

#endif
