// CookTorranceMaterial, correct: k_d cos(alpha) + F D G / (4 N.V), Beckmann D, Schlick F with ks as F_0.
#ifndef COOKTORRANCEMATERIAL_H
#define COOKTORRANCEMATERIAL_H

#include "Material.h"

class CookTorranceMaterial : public Material
{
  public:
    Real roughness; // Beckmann m
    vec3 ks;        // Fresnel reflectance at normal incidence
    vec3 kd;        // diffuse reflectance

    CookTorranceMaterial() : roughness(0.3), ks(0), kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
    {
        vec3 N = record.normal;
        vec3 L = incomingDir;
        vec3 V = outgoingDir;
        Real cosAlpha = -dot(N, L);
        if (cosAlpha <= 0)
            return vec3(0, 0, 0);
        vec3 diffuse = kd * cosAlpha;
        Real nv = dot(N, V);
        if (nv <= 0)
            return diffuse;
        vec3 H = normalize(V - L);
        Real nh = dot(N, H);
        Real vh = dot(V, H);
        if (nh <= 0 || vh <= 0)
            return diffuse;
        // Beckmann distribution
        Real m2 = roughness * roughness;
        Real nh2 = nh * nh;
        Real tan2 = (1 - nh2) / nh2;
        Real D = exp(-tan2 / m2) / (M_PI * m2 * nh2 * nh2);
        // geometric attenuation
        Real G = std::min(1.0, std::min(2 * nh * nv / vh, 2 * nh * cosAlpha / vh));
        // Schlick
        Real s = pow(1 - vh, 5);
        vec3 F = ks + (vec3(1) - ks) * s;
        return diffuse + F * (D * G / (4 * nv));
    }
};

#endif
