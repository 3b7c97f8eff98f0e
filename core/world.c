#include "world.h"

#include <stdlib.h>
#include <string.h>

void rd_world_free(rd_world *w)
{
    free(w->spheres);
    free(w->sphere_mat);
    free(w->sphere_obj);
    free(w->planes);
    free(w->plane_mat);
    free(w->plane_obj);
    free(w->tris);
    free(w->tri_mat);
    free(w->tri_obj);
    memset(w, 0, sizeof *w);
}

rd_error_code rd_world_build(rd_world *w, const rd_scene *s, rd_error *err)
{
    memset(w, 0, sizeof *w);
    w->origin = s->camera.eye;
    size_t ns = 0, np = 0, nt = 0;
    for (size_t i = 0; i < s->object_count; i++) {
        const rd_object *o = &s->objects[i];
        if (o->material < 0 || (size_t)o->material >= s->material_count)
            return rd_error_set(err, RD_ERR_INVALID, 0, 0, "object %zu has no material", i);
        ns += o->type == RD_OBJ_SPHERE;
        np += o->type == RD_OBJ_PLANE;
        nt += o->type == RD_OBJ_TRIANGLE;
        if (o->type == RD_OBJ_MESH)
            return rd_error_set(err, RD_ERR_INVALID, 0, 0,
                                "object %zu: meshes must be expanded into triangles before rendering", i);
    }
    w->spheres = calloc(ns + 1, sizeof *w->spheres);
    w->sphere_mat = calloc(ns + 1, sizeof(int));
    w->sphere_obj = calloc(ns + 1, sizeof(int));
    w->planes = calloc(np + 1, sizeof *w->planes);
    w->plane_mat = calloc(np + 1, sizeof(int));
    w->plane_obj = calloc(np + 1, sizeof(int));
    w->tris = calloc(nt + 1, sizeof *w->tris);
    w->tri_mat = calloc(nt + 1, sizeof(int));
    w->tri_obj = calloc(nt + 1, sizeof(int));
    if (!w->spheres || !w->sphere_mat || !w->sphere_obj || !w->planes || !w->plane_mat ||
        !w->plane_obj || !w->tris || !w->tri_mat || !w->tri_obj) {
        rd_world_free(w);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory preparing the scene");
    }
    for (size_t i = 0; i < s->object_count; i++) {
        const rd_object *o = &s->objects[i];
        switch (o->type) {
        case RD_OBJ_SPHERE: {
            size_t k = w->nspheres++;
            w->spheres[k].c = rd_world_local(w, o->center);
            w->spheres[k].r = o->radius;
            w->sphere_mat[k] = o->material;
            w->sphere_obj[k] = (int)i;
            break;
        }
        case RD_OBJ_PLANE: {
            size_t k = w->nplanes++;
            rd_plane_make(&w->planes[k], rd_world_local(w, o->point), o->normal);
            w->planes[k].uv_scale = s->materials[o->material].uv_scale;
            w->plane_mat[k] = o->material;
            w->plane_obj[k] = (int)i;
            break;
        }
        case RD_OBJ_TRIANGLE: {
            size_t k = w->ntris++;
            rd_triangle *t = &w->tris[k];
            t->v0 = rd_world_local(w, o->v[0]);
            t->v1 = rd_world_local(w, o->v[1]);
            t->v2 = rd_world_local(w, o->v[2]);
            t->has_normals = o->has_normals;
            if (o->has_normals) {
                t->n0 = v3_normalize(o->n[0]);
                t->n1 = v3_normalize(o->n[1]);
                t->n2 = v3_normalize(o->n[2]);
            }
            t->has_uv = o->has_uv;
            memcpy(t->uv, o->uv, sizeof t->uv);
            w->tri_mat[k] = o->material;
            w->tri_obj[k] = (int)i;
            break;
        }
        case RD_OBJ_MESH:
            break;
        }
    }
    return RD_OK;
}

int rd_world_closest(const rd_world *w, rd_ray r, double tmax, rd_hit *h)
{
    double best = tmax;
    int kind = -1;
    size_t idx = 0;
    double bary[3] = {0, 0, 0}, b[3];
    for (size_t i = 0; i < w->nspheres; i++) {
        double t = rd_sphere_intersect(&w->spheres[i], r, best);
        if (t > 0) {
            best = t;
            kind = 0;
            idx = i;
        }
    }
    for (size_t i = 0; i < w->nplanes; i++) {
        double t = rd_plane_intersect(&w->planes[i], r, best);
        if (t > 0) {
            best = t;
            kind = 1;
            idx = i;
        }
    }
    for (size_t i = 0; i < w->ntris; i++) {
        double t = rd_triangle_intersect(&w->tris[i], r, best, b);
        if (t > 0) {
            best = t;
            kind = 2;
            idx = i;
            memcpy(bary, b, sizeof bary);
        }
    }
    if (kind < 0)
        return 0;
    h->t = best;
    h->u = h->v = 0;
    if (kind == 0) {
        rd_sphere_fill_hit(&w->spheres[idx], r, h);
        h->n = h->ng;
        h->material = w->sphere_mat[idx];
        h->object = w->sphere_obj[idx];
    } else if (kind == 1) {
        rd_plane_fill_hit(&w->planes[idx], r, h);
        h->n = h->ng;
        h->material = w->plane_mat[idx];
        h->object = w->plane_obj[idx];
    } else {
        rd_triangle_fill_hit(&w->tris[idx], bary, h);
        h->material = w->tri_mat[idx];
        h->object = w->tri_obj[idx];
    }
    h->front = v3_dot(h->ng, r.d) < 0;
    if (v3_dot(h->n, r.d) > 0)
        h->n = v3_neg(h->n);
    return 1;
}

int rd_world_any(const rd_world *w, rd_ray r, double tmax)
{
    double b[3];
    for (size_t i = 0; i < w->nspheres; i++)
        if (rd_sphere_intersect(&w->spheres[i], r, tmax) > 0)
            return 1;
    for (size_t i = 0; i < w->nplanes; i++)
        if (rd_plane_intersect(&w->planes[i], r, tmax) > 0)
            return 1;
    for (size_t i = 0; i < w->ntris; i++)
        if (rd_triangle_intersect(&w->tris[i], r, tmax, b) > 0)
            return 1;
    return 0;
}
