#include "scene_limits.h"

#include <stddef.h>

#define F(x) offsetof(rd_scene_limits, x)

/* The old --max-NAME spellings are still read for one release; --max-depth
 * is not, since it is now the render override of the scene's max_depth. */
static const rd_limit_info info[] = {
    {"--limit-scene-bytes", "--max-scene-bytes", F(max_bytes), "bytes of scene text"},
    {"--limit-pixels", "--max-pixels", F(max_pixels), "pixels in an image (width x height)"},
    {"--limit-samples", "--max-samples", F(max_samples), "samples per pixel"},
    {"--limit-depth", NULL, F(max_depth), "mirror/refraction bounces"},
    {"--limit-objects", "--max-objects", F(max_objects), "spheres, planes and triangles"},
    {"--limit-lights", "--max-lights", F(max_lights), "lights"},
    {"--limit-materials", "--max-materials", F(max_materials), "materials"},
    {"--limit-name-bytes", "--max-name-bytes", F(max_name), "bytes in a name or string"},
    {"--limit-nesting", "--max-nesting", F(max_nesting), "JSON nesting depth"},
    {"--limit-mesh-bytes", "--max-mesh-bytes", F(max_mesh_bytes), "bytes of one OBJ mesh file"},
    {"--limit-texture-bytes", "--max-texture-bytes", F(max_texture_bytes), "bytes of one PNG texture file"},
    {"--limit-texture-pixels", "--max-texture-pixels", F(max_texture_pixels), "pixels of one texture"},
};

const rd_limit_info *rd_limits_info(size_t *count)
{
    *count = sizeof info / sizeof info[0];
    return info;
}

const char *rd_limit_flag(size_t offset)
{
    for (size_t i = 0; i < sizeof info / sizeof info[0]; i++)
        if (info[i].offset == offset)
            return info[i].flag;
    return "?";
}

rd_scene_limits rd_scene_limits_default(void)
{
    rd_scene_limits l;
    l.max_bytes = 16u << 20;
    l.max_pixels = 4096u * 4096u;
    l.max_samples = 65536;
    l.max_depth = 64;
    l.max_objects = 1000000;
    l.max_lights = 1024;
    l.max_materials = 4096;
    l.max_name = 256;
    l.max_nesting = 16;
    l.max_mesh_bytes = 256u << 20;
    l.max_texture_bytes = 64u << 20;
    l.max_texture_pixels = 8192u * 8192u;
    return l;
}

rd_error_code rd_scene_check_limits(const rd_scene *s, const rd_scene_limits *lim_in, const char *source, rd_error *err)
{
    rd_scene_limits lim = lim_in ? *lim_in : rd_scene_limits_default();
    source = source ? source : "<scene>";
    size_t pixels = (size_t)s->render.width * (size_t)s->render.height;
    if (pixels > lim.max_pixels)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "%s: %dx%d is %zu pixels, over the limit of %zu (%s)", source,
                            s->render.width, s->render.height, pixels, lim.max_pixels, rd_limit_flag(F(max_pixels)));
    if ((size_t)s->render.samples > lim.max_samples)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "%s: %d samples per pixel, over the limit of %zu (%s)", source,
                            s->render.samples, lim.max_samples, rd_limit_flag(F(max_samples)));
    if ((size_t)s->render.max_depth > lim.max_depth)
        return rd_error_set(err, RD_ERR_LIMIT, 0, 0, "%s: max_depth %d, over the limit of %zu (%s)", source,
                            s->render.max_depth, lim.max_depth, rd_limit_flag(F(max_depth)));
    return RD_OK;
}
