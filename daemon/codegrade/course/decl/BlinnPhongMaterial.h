/* BlinnPhongMaterial: diffuse plus Blinn's half-vector variant of Phong's
 * glossy reflection.
 * calcReflectedLight is only declared: a .cpp that includes this file
 * defines vec3 BlinnPhongMaterial::calcReflectedLight(...). */
#ifndef BLINNPHONGMATERIAL_H
#define BLINNPHONGMATERIAL_H

#include "Material.h"

class BlinnPhongMaterial : public Material
{
  public:
    Real shininess; // n of cos^n
    vec3 ks;        // specular reflectance k_s, per RGB channel
    vec3 kd;        // diffuse reflectance k_d, per RGB channel

    BlinnPhongMaterial() : shininess(1), ks(0), kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir);
};

#endif
