// Hostile PhongMaterial: writes through a null pointer (SIGSEGV).
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
        // NULL at run time; the compiler cannot see it, so the store stays.
        volatile int *p = (volatile int *)std::getenv("RAYD_NO_SUCH_VARIABLE");
        *p = 1;
        Real cosAlpha = -dot(record.normal, incomingDir);
        if (cosAlpha <= 0)
            return vec3(0, 0, 0);
        vec3 R = reflect(incomingDir, record.normal);
        return kd * cosAlpha + ks * pow(std::max(dot(R, outgoingDir), 0.0), shininess);
    }
};

#endif
