/* Render settings given outside the scene: `rayd render --width 320`,
 * `POST /v1/render?samples=64`. Each value is read and range-checked
 * through the key table (scene_keys.h), so a flag, a query parameter and
 * the scene key it overrides accept exactly the same values. */
#ifndef RD_SCENE_OVERRIDES_H
#define RD_SCENE_OVERRIDES_H

#include "rayd/error.h"
#include "rayd/scene.h"

/* The render keys that can be overridden, NULL-terminated: width, height,
 * samples, max_depth, gamma, seed. */
extern const char *const rd_override_names[];

typedef struct {
    unsigned set;              /* bit i: rd_override_names[i] was given */
    rd_render_settings values; /* those given */
} rd_scene_overrides;

/* Reads value for the render key name into ov. RD_ERR_NOT_FOUND when name
 * cannot be overridden; RD_ERR_SYNTAX when the value is not one the scene
 * key takes, with a message "WHAT: expected ..., got '...'" where WHAT is
 * what (e.g. "query parameter width", "--width"). */
rd_error_code rd_override_set(rd_scene_overrides *ov, const char *name, const char *value, const char *what,
                              rd_error *err);

/* Whether the render key name was given. */
int rd_override_given(const rd_scene_overrides *ov, const char *name);

/* Copies the values given into s's render section. */
void rd_overrides_apply(const rd_scene_overrides *ov, rd_scene *s);

#endif
