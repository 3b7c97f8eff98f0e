/* The fixed configurations a student's calcReflectedLight is called on
 * (docs/grading.md, "Grading code: the configurations"): for each material
 * a student writes, some 3000 (normal, incoming, outgoing, material)
 * in groups that each catch a kind of mistake. Deterministic: the same
 * list on every machine and every run. */
#ifndef RD_CODE_CASES_H
#define RD_CODE_CASES_H

#include <stddef.h>

#include "assignment.h"
#include "rayd/error.h"
#include "rayd/scene.h"

#define RD_CODE_GROUPS_X(X)                                                                                            \
    X(GENERAL, "general", "light and eye in front, anywhere")                                                          \
    X(BACK_LIT, "back_lit", "the light behind the surface")                                                            \
    X(GRAZING, "grazing", "the light almost along the surface")                                                        \
    X(MIRROR, "mirror", "the eye in the mirror direction")                                                             \
    X(NORMAL_INCIDENCE, "normal_incidence", "the light along the normal")                                              \
    X(RETRO, "retro", "the eye where the light comes from")                                                            \
    X(VIEW_GRAZING, "view_grazing", "the eye almost along the surface")                                                \
    X(STIFF, "stiff", "extreme shininess or roughness near the highlight")                                             \
    X(LOBE, "lobe", "the eye swept across the plane of incidence")

typedef enum {
#define RD_CODE_GROUP_ENUM(id, word, words) RD_CODE_##id,
    RD_CODE_GROUPS_X(RD_CODE_GROUP_ENUM)
#undef RD_CODE_GROUP_ENUM
        RD_CODE_GROUPS
} rd_code_group;

typedef struct {
    rd_material m; /* type and parameters; no name, no texture */
    rd_vec3 n;     /* unit normal */
    rd_vec3 L;     /* unit, from the light to the surface (incomingDir) */
    rd_vec3 V;     /* unit, from the surface to the eye (outgoingDir) */
    rd_code_group group;
    double angle_deg;     /* LOBE: the eye's angle from the normal, toward the mirror direction positive */
    double incidence_deg; /* LOBE: the light's angle from the normal */
} rd_code_case;

/* The configurations of a material type: diffuse, phong, blinn_phong or
 * cook_torrance (RD_ERR_UNSUPPORTED for any other), their shininess drawn
 * from the assignment's domain. *cases is malloc'ed (the caller frees it);
 * RD_ERR_NOMEM. */
rd_error_code rd_code_cases(rd_material_type type, rd_shininess_domain shininess, rd_code_case **cases, size_t *n,
                            rd_error *err);

/* "general", "back_lit", ...; and what the group is, in words. */
const char *rd_code_group_name(rd_code_group g);
const char *rd_code_group_words(rd_code_group g);

#endif
