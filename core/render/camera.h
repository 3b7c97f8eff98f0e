/* The pinhole camera of shading.md. */
#ifndef RD_CAMERA_H
#define RD_CAMERA_H

#include "ray.h"
#include "rayd/error.h"
#include "rayd/scene.h"

typedef struct {
    rd_vec3 u, v, w;
    double h, aspect;
    int width, height;
} rd_pinhole;

/* Basis from eye, target, up and fov; RD_ERR_INVALID when eye == target,
 * up is parallel to the view, or fov is outside (0, 180). */
rd_error_code rd_pinhole_make(rd_pinhole *c, const rd_camera *cam, int width, int height, rd_error *err);

/* Ray from the eye (the origin: the world is camera-relative) through image
 * point (x, y), x right in [0, width), y down in [0, height). Unit direction. */
rd_ray rd_pinhole_ray(const rd_pinhole *c, double x, double y);

#endif
