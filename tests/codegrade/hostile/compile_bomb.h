// Hostile PhongMaterial: about 1024 constant evaluations of about a second each, so g++ takes some
// 15 minutes (and little memory) to compile it; it does compile, to a correct Phong.
#ifndef PHONGMATERIAL_H
#define PHONGMATERIAL_H

#include "Material.h"

// Each call stays under g++'s -fconstexpr-ops-limit and keeps few distinct values alive;
// a distinct seed per call defeats the cache of constexpr calls.
constexpr unsigned long spin(unsigned long seed)
{
    unsigned long s = seed;
    for (int i = 0; i < 1000; i++)
        for (int j = 0; j < 1000; j++)
            s = (s * 31 + 7) % 1021;
    return s;
}

#define SPIN1(k) static_assert(spin(k) < 1021, "");
#define SPIN4(k) SPIN1(k##0) SPIN1(k##1) SPIN1(k##2) SPIN1(k##3)
#define SPIN16(k) SPIN4(k##0) SPIN4(k##1) SPIN4(k##2) SPIN4(k##3)
#define SPIN64(k) SPIN16(k##0) SPIN16(k##1) SPIN16(k##2) SPIN16(k##3)
#define SPIN256(k) SPIN64(k##0) SPIN64(k##1) SPIN64(k##2) SPIN64(k##3)
SPIN256(1)
SPIN256(2)
SPIN256(3)
SPIN256(4)

class PhongMaterial : public Material
{
  public:
    Real shininess; // n of cos^n
    vec3 ks;        // specular reflectance
    vec3 kd;        // diffuse reflectance

    PhongMaterial() : shininess(1), ks(0), kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
    {
        Real cosAlpha = -dot(record.normal, incomingDir);
        if (cosAlpha <= 0)
            return vec3(0, 0, 0);
        vec3 R = reflect(incomingDir, record.normal);
        return kd * cosAlpha + ks * pow(std::max(dot(R, outgoingDir), 0.0), shininess);
    }
};

#endif
