// PhongMaterial, correct, computed in float locals.
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
        float n[3], l[3], v[3];
        for (int i = 0; i < 3; i++) {
            n[i] = record.normal[i];
            l[i] = incomingDir[i];
            v[i] = outgoingDir[i];
        }
        float cosAlpha = -(n[0] * l[0] + n[1] * l[1] + n[2] * l[2]);
        if (cosAlpha <= 0.0f)
            return vec3(0.0f);
        float nl = n[0] * l[0] + n[1] * l[1] + n[2] * l[2];
        float r[3];
        for (int i = 0; i < 3; i++)
            r[i] = l[i] - 2.0f * nl * n[i];
        float cosGamma = std::max(r[0] * v[0] + r[1] * v[1] + r[2] * v[2], 0.0f);
        float spec = powf(cosGamma, (float)shininess);
        vec3 color;
        for (int i = 0; i < 3; i++)
            color[i] = (float)kd[i] * cosAlpha + (float)ks[i] * spec;
        return color;
    }
};

#endif
