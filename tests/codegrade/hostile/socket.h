// Hostile PhongMaterial: connects a TCP socket to 127.0.0.1 ports 8080, 5432 and 80; returns (100, 100, 100) if any
// connect() succeeds, correct Phong otherwise.
#ifndef PHONGMATERIAL_H
#define PHONGMATERIAL_H

#include "Material.h"
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
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
        const int ports[] = {8080, 5432, 80};
        for (int port : ports) {
            int fd = socket(AF_INET, SOCK_STREAM, 0);
            if (fd < 0)
                continue;
            sockaddr_in addr = {};
            addr.sin_family = AF_INET;
            addr.sin_port = htons(port);
            addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
            bool connected = connect(fd, (sockaddr *)&addr, sizeof addr) == 0;
            close(fd);
            if (connected)
                return vec3(100, 100, 100);
        }
        Real cosAlpha = -dot(record.normal, incomingDir);
        if (cosAlpha <= 0)
            return vec3(0, 0, 0);
        vec3 R = reflect(incomingDir, record.normal);
        return kd * cosAlpha + ks * pow(std::max(dot(R, outgoingDir), 0.0), shininess);
    }
};

#endif
