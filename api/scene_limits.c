#include "scene_limits.h"

rd_scene_limits rd_scene_limits_default(void)
{
    rd_scene_limits l;
    l.max_bytes = 16u << 20;
    l.max_objects = 1000000;
    l.max_lights = 1024;
    l.max_materials = 4096;
    l.max_name = 256;
    return l;
}
