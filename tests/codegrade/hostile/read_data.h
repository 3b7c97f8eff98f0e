// Hostile PhongMaterial: tries files and environment variables outside the sandbox; returns (100, 100, 100 + i) for the
// first of them that opened or is set, correct Phong otherwise.
#ifndef PHONGMATERIAL_H
#define PHONGMATERIAL_H

#include "Material.h"
#include <cstdlib>
#include <fcntl.h>
#include <unistd.h>

class PhongMaterial : public Material
{
  public:
    Real shininess; // n of cos^n
    vec3 ks;        // specular reflectance
    vec3 kd;        // diffuse reflectance

    PhongMaterial() : shininess(1), ks(0), kd(0) {}

    virtual vec3 calcReflectedLight(const HitRecord &record, const vec3 &incomingDir, const vec3 &outgoingDir)
    {
        const char *paths[] = {"/etc/shadow", "/root/.bashrc", "/proc/1/environ", "/var/lib/rayd", "/work"};
        const char *vars[] = {"HOME", "USER", "PGPASSWORD", "PGHOST", "DATABASE_URL", "RAYD_DB"};
        int i = 0;
        for (const char *path : paths) {
            int fd = open(path, O_RDONLY);
            if (fd >= 0) {
                close(fd);
                return vec3(100, 100, 100 + i);
            }
            i++;
        }
        for (const char *var : vars) {
            if (getenv(var))
                return vec3(100, 100, 100 + i);
            i++;
        }
        Real cosAlpha = -dot(record.normal, incomingDir);
        if (cosAlpha <= 0)
            return vec3(0, 0, 0);
        vec3 R = reflect(incomingDir, record.normal);
        return kd * cosAlpha + ks * pow(std::max(dot(R, outgoingDir), 0.0), shininess);
    }
};

#endif
