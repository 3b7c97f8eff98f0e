// Hostile PhongMaterial: tries the host's files, folders and environment variables; returns (100, 100, 100 + i) for
// the first of them that it could read, open or find set, correct Phong otherwise.
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
        // The host's files and folders, and the daemon's environment; the
        // sandbox's own /work, /tmp and HOME=/work do not count.
        const char *files[] = {"/etc/shadow", "/etc/passwd", "/root/.bashrc", "/proc/1/environ"};
        const char *dirs[] = {"/home", "/root", "/var/lib/rayd", "/etc"};
        const char *vars[] = {"USER", "PGPASSWORD", "PGHOST", "DATABASE_URL", "RAYD_DATA_DIR", "RAYD_STORE"};
        int i = 0;
        for (const char *path : files) {
            char c;
            int fd = open(path, O_RDONLY);
            ssize_t got = fd >= 0 ? read(fd, &c, 1) : -1;
            if (fd >= 0)
                close(fd);
            if (got > 0)
                return vec3(100, 100, 100 + i);
            i++;
        }
        for (const char *path : dirs) {
            int fd = open(path, O_RDONLY | O_DIRECTORY);
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
