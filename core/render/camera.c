#include "camera.h"

rd_error_code rd_pinhole_make(rd_pinhole *c, const rd_camera *cam, int width, int height, rd_error *err)
{
    if (!(cam->fov_deg > 0 && cam->fov_deg < 180))
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "camera fov must be in (0, 180)");
    if (width < 1 || height < 1)
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "image size must be at least 1x1");
    rd_vec3 view = v3_sub(cam->eye, cam->target);
    if (!(v3_max_abs(view) > 0))
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "camera eye and target are the same point");
    c->w = v3_normalize(view);
    rd_vec3 side = v3_cross(v3_normalize(cam->up), c->w);
    /* Unit vectors that are parallel up to rounding have a cross product of
     * a few ulps, not exactly zero: its length is the sine of their angle. */
    if (!(v3_len(side) > RD_MIN_UP_SINE))
        return rd_error_set(err, RD_ERR_INVALID, 0, 0, "camera up is parallel to the view direction");
    c->u = v3_normalize(side);
    c->v = v3_cross(c->w, c->u);
    c->h = tan(cam->fov_deg * M_PI / 360.0);
    c->aspect = (double)width / (double)height;
    c->width = width;
    c->height = height;
    return RD_OK;
}

rd_ray rd_pinhole_ray(const rd_pinhole *c, double x, double y)
{
    double sx = (2.0 * x / c->width - 1.0) * c->aspect * c->h;
    double sy = (1.0 - 2.0 * y / c->height) * c->h;
    rd_ray r;
    r.o = v3(0, 0, 0);
    r.d = v3_normalize(v3_sub(v3_add(v3_scale(c->u, sx), v3_scale(c->v, sy)), c->w));
    return r;
}
