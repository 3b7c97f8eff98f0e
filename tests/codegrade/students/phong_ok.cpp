// PhongMaterial, correct, as a .cpp that defines the function the declaration-only PhongMaterial.h declares.
#include "PhongMaterial.h"

vec3 PhongMaterial::calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
{
    const vec3 &N = record.normal;
    Real cosAlpha = -N.dot(incomingDir);
    if (cosAlpha <= 0)
        return vec3(0);
    vec3 R = reflect(incomingDir, N);
    Real cosGamma = max(R.dot(outgoingDir), 0.0);
    vec3 color = kd * cosAlpha;
    color += ks * pow(cosGamma, shininess);
    return color;
}
