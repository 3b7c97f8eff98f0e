// Hostile PhongMaterial: forks children that sleep until fork() fails (RLIMIT_NPROC), prints how many it made, and
// holds them for four calls of a second each, so that another grade can start meanwhile. Correct Phong otherwise:
// the sandbox's process limit must be its own, not one shared with the daemon and every other sandbox.
#ifndef PHONGMATERIAL_H
#define PHONGMATERIAL_H

#include "Material.h"
#include <cstdio>
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
        static int calls;
        if (calls == 0) {
            int made = 0;
            for (pid_t p; made < 1000 && (p = fork()) >= 0; made++)
                if (p == 0) {
                    sleep(30);
                    _exit(0);
                }
            printf("forked %d\n", made);
            fflush(stdout);
        }
        if (calls++ < 4)
            usleep(1000000);
        Real cosAlpha = -dot(record.normal, incomingDir);
        if (cosAlpha <= 0)
            return vec3(0, 0, 0);
        vec3 R = reflect(incomingDir, record.normal);
        return kd * cosAlpha + ks * pow(std::max(dot(R, outgoingDir), 0.0), shininess);
    }
};

#endif
