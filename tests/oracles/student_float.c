/* A student's renderer in single precision: see student_float.h. Written
 * from shading.md alone (plus rayd's documented conventions where
 * shading.md is silent), with none of core/'s robustness machinery: no
 * camera-relative coordinates, no error bounds, no re-projection, just
 * "ignore hits closer than eps" (SF_EPS_DEFAULT unless asked). */
#include "student_float.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define SF_PI 3.14159265358979f

typedef struct {
    float x, y, z;
} fvec;

static fvec fv(float x, float y, float z)
{
    fvec r;
    r.x = x;
    r.y = y;
    r.z = z;
    return r;
}
static fvec fv_of(rd_vec3 a) { return fv((float)a.x, (float)a.y, (float)a.z); }
static fvec fadd(fvec a, fvec b) { return fv(a.x + b.x, a.y + b.y, a.z + b.z); }
static fvec fsub(fvec a, fvec b) { return fv(a.x - b.x, a.y - b.y, a.z - b.z); }
static fvec fmulv(fvec a, fvec b) { return fv(a.x * b.x, a.y * b.y, a.z * b.z); }
static fvec fscale(fvec a, float s) { return fv(a.x * s, a.y * s, a.z * s); }
static fvec fneg(fvec a) { return fv(-a.x, -a.y, -a.z); }
static float fdot(fvec a, fvec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static fvec fcross(fvec a, fvec b) { return fv(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x); }
static fvec fnormalize(fvec a)
{
    float l = sqrtf(fdot(a, a));
    return l > 0 ? fscale(a, 1.0f / l) : a;
}
/* The course's my_algebra.h: reflect(i, n) = i - 2(i·n)n. */
static fvec freflect(fvec i, fvec n) { return fsub(i, fscale(n, 2.0f * fdot(i, n))); }
static float fclamp01(float c) { return !(c > 0) ? 0 : (c > 1 ? 1 : c); }

typedef struct {
    fvec c;
    float r;
    int mat;
} sf_sphere;

typedef struct {
    fvec q, n;   /* a point and the unit normal as written */
    fvec tu, tv; /* texture axes */
    int mat;
} sf_plane;

typedef struct {
    fvec v0, v1, v2;
    fvec n0, n1, n2;
    float uv[3][2];
    int has_n;
    int mat;
} sf_tri;

typedef struct {
    rd_light_type type;
    fvec color, pos, dir;
    float cos_cut, falloff;
    fvec corner, e1, e2;
    int side;
} sf_light;

typedef struct {
    rd_material_type type;
    fvec kd, ks, ambient;
    float shininess, roughness, ior, uv_scale;
    const rd_texture *tex;
} sf_mat;

typedef struct {
    sf_sphere *sph;
    size_t nsph;
    sf_plane *pl;
    size_t npl;
    sf_tri *tri;
    size_t ntri;
    sf_light *lights;
    size_t nlights;
    sf_mat *mats;
    fvec background;
    int max_depth;
    unsigned bugs;
    float eps; /* hits closer than this along any ray are ignored */
} sf_world;

enum { K_NONE, K_SPHERE, K_PLANE, K_TRI };

typedef struct {
    float t;
    int kind;
    size_t idx;
    float b1, b2; /* triangle barycentrics of v1 and v2 */
} sf_hit;

const char *sf_bug_name(unsigned bug)
{
    switch (bug) {
    case SF_CORRECT: return "correct";
    case SF_BUG_NO_MAX_COS: return "no_max_cos";
    case SF_BUG_REFLECT_SIGN: return "reflect_sign";
    case SF_BUG_BLINN_FOR_PHONG: return "blinn_for_phong";
    case SF_BUG_SHININESS_HALVED: return "shininess_half";
    case SF_BUG_LIGHT_REVERSED: return "light_reversed";
    case SF_BUG_NO_AMBIENT: return "no_ambient";
    case SF_BUG_AMBIENT_PER_LIGHT: return "ambient_per_light";
    case SF_BUG_GAMMA_TWICE: return "gamma_twice";
    default: return NULL;
    }
}

/* ---- intersection ---------------------------------------------------- */

static float hit_sphere(const sf_sphere *s, fvec o, fvec d, float tmin, float tmax)
{
    fvec oc = fsub(o, s->c);
    float b = fdot(oc, d);
    float c = fdot(oc, oc) - s->r * s->r;
    float disc = b * b - c;
    if (disc < 0)
        return -1;
    float sq = sqrtf(disc);
    float t = -b - sq;
    if (t <= tmin)
        t = -b + sq;
    return (t > tmin && t < tmax) ? t : -1;
}

static float hit_plane(const sf_plane *p, fvec o, fvec d, float tmin, float tmax)
{
    float dn = fdot(d, p->n);
    if (dn == 0)
        return -1;
    float t = fdot(fsub(p->q, o), p->n) / dn;
    return (t > tmin && t < tmax) ? t : -1;
}

/* Möller-Trumbore. */
static float hit_tri(const sf_tri *tr, fvec o, fvec d, float tmin, float tmax, float *b1, float *b2)
{
    fvec e1 = fsub(tr->v1, tr->v0), e2 = fsub(tr->v2, tr->v0);
    fvec pv = fcross(d, e2);
    float det = fdot(e1, pv);
    if (fabsf(det) < 1e-12f)
        return -1;
    float inv = 1.0f / det;
    fvec tv = fsub(o, tr->v0);
    float u = fdot(tv, pv) * inv;
    if (u < 0 || u > 1)
        return -1;
    fvec qv = fcross(tv, e1);
    float v = fdot(d, qv) * inv;
    if (v < 0 || u + v > 1)
        return -1;
    float t = fdot(e2, qv) * inv;
    if (!(t > tmin && t < tmax))
        return -1;
    *b1 = u;
    *b2 = v;
    return t;
}

static int closest(const sf_world *w, fvec o, fvec d, float tmin, sf_hit *h)
{
    h->t = INFINITY;
    h->kind = K_NONE;
    h->idx = 0;
    h->b1 = h->b2 = 0;
    for (size_t i = 0; i < w->nsph; i++) {
        float t = hit_sphere(&w->sph[i], o, d, tmin, h->t);
        if (t > 0) {
            h->t = t;
            h->kind = K_SPHERE;
            h->idx = i;
        }
    }
    for (size_t i = 0; i < w->npl; i++) {
        float t = hit_plane(&w->pl[i], o, d, tmin, h->t);
        if (t > 0) {
            h->t = t;
            h->kind = K_PLANE;
            h->idx = i;
        }
    }
    for (size_t i = 0; i < w->ntri; i++) {
        float b1, b2;
        float t = hit_tri(&w->tri[i], o, d, tmin, h->t, &b1, &b2);
        if (t > 0) {
            h->t = t;
            h->kind = K_TRI;
            h->idx = i;
            h->b1 = b1;
            h->b2 = b2;
        }
    }
    return h->kind != K_NONE;
}

static int occluded(const sf_world *w, fvec o, fvec d, float dist)
{
    for (size_t i = 0; i < w->nsph; i++)
        if (hit_sphere(&w->sph[i], o, d, w->eps, dist) > 0)
            return 1;
    for (size_t i = 0; i < w->npl; i++)
        if (hit_plane(&w->pl[i], o, d, w->eps, dist) > 0)
            return 1;
    for (size_t i = 0; i < w->ntri; i++) {
        float b1, b2;
        if (hit_tri(&w->tri[i], o, d, w->eps, dist, &b1, &b2) > 0)
            return 1;
    }
    return 0;
}

/* ---- textures -------------------------------------------------------- */

static fvec texel(const rd_texture *t, int i, int j)
{
    i %= t->width;
    j %= t->height;
    if (i < 0)
        i += t->width;
    if (j < 0)
        j += t->height;
    const float *p = &t->rgb[3 * ((size_t)j * (size_t)t->width + (size_t)i)];
    return fv(p[0], p[1], p[2]);
}

/* Bilinear with wrap. shading.md says only "bilinear, wrap"; texel (i, j)
 * is centred at ((i + 0.5)/width, (j + 0.5)/height), v = 0 the top row, as
 * core/shading/texture.h documents (not shading.md: a student cannot know it). */
static fvec texture_bilinear(const rd_texture *t, float u, float v)
{
    u -= floorf(u);
    v -= floorf(v);
    float x = u * (float)t->width - 0.5f, y = v * (float)t->height - 0.5f;
    float x0 = floorf(x), y0 = floorf(y);
    float fx = x - x0, fy = y - y0;
    int i = (int)x0, j = (int)y0;
    fvec a = fadd(fscale(texel(t, i, j), 1 - fx), fscale(texel(t, i + 1, j), fx));
    fvec b = fadd(fscale(texel(t, i, j + 1), 1 - fx), fscale(texel(t, i + 1, j + 1), fx));
    return fadd(fscale(a, 1 - fy), fscale(b, fy));
}

/* shading.md: "plane from two axes perpendicular to its normal, times
 * uv_scale" -- which two, and which way round, it does not say. This takes
 * the coordinate axis least aligned with n (x, else y, else z, by |n_i| <
 * 0.5), tu = normalize(a × n), tv = n × tu, and coordinates relative to the
 * plane's point: rayd's choice (core/geometry/plane.c), the only way to agree. */
static void plane_axes(sf_plane *p)
{
    fvec a;
    if (fabsf(p->n.x) < 0.5f)
        a = fv(1, 0, 0);
    else if (fabsf(p->n.y) < 0.5f)
        a = fv(0, 1, 0);
    else
        a = fv(0, 0, 1);
    p->tu = fnormalize(fcross(a, p->n));
    p->tv = fcross(p->n, p->tu);
}

/* ---- shading --------------------------------------------------------- */

/* calcReflectedLight: L from the light to the surface (incomingDir), V from
 * the surface to the eye (outgoingDir), N the unit normal facing V. */
static fvec calc_reflected_light(const sf_mat *m, fvec kd, fvec N, fvec L, fvec V, unsigned bugs)
{
    fvec zero = fv(0, 0, 0);
    float cosa = -fdot(N, L);
    if (!(bugs & SF_BUG_NO_MAX_COS)) {
        if (cosa <= 0)
            return zero; /* behind: no diffuse, no highlight */
    }
    fvec diffuse = fscale(kd, cosa);
    float n = m->shininess;
    if (bugs & SF_BUG_SHININESS_HALVED)
        n *= 0.5f;
    switch (m->type) {
    case RD_MAT_DIFFUSE: return diffuse;
    case RD_MAT_PHONG:
    case RD_MAT_TEXTURED_PHONG: {
        float c;
        if (bugs & SF_BUG_BLINN_FOR_PHONG) {
            fvec H = fnormalize(fsub(V, L));
            c = fdot(N, H);
        } else {
            fvec R = freflect(L, N);
            if (bugs & SF_BUG_REFLECT_SIGN)
                R = fneg(R);
            c = fdot(R, V);
        }
        float spec = c > 0 ? powf(c, n) : 0;
        return fadd(diffuse, fscale(m->ks, spec));
    }
    case RD_MAT_BLINN_PHONG: {
        fvec H = fnormalize(fsub(V, L));
        float c = fdot(N, H);
        float spec = c > 0 ? powf(c, n) : 0;
        return fadd(diffuse, fscale(m->ks, spec));
    }
    case RD_MAT_COOK_TORRANCE: {
        float nv = fdot(N, V);
        if (nv <= 0)
            return diffuse;
        fvec H = fnormalize(fsub(V, L));
        float nh = fdot(N, H), vh = fdot(V, H);
        if (nh <= 0 || vh <= 0)
            return diffuse;
        float m2 = m->roughness * m->roughness, nh2 = nh * nh;
        /* Beckmann: exp(-tan²θ/m²) / (π m² cos⁴θ). */
        float D = expf((nh2 - 1.0f) / (nh2 * m2)) / (SF_PI * m2 * nh2 * nh2);
        float G = fminf(1.0f, fminf(2 * nh * nv / vh, 2 * nh * cosa / vh));
        float s5 = powf(1 - vh, 5);
        fvec F = fv(m->ks.x + (1 - m->ks.x) * s5, m->ks.y + (1 - m->ks.y) * s5, m->ks.z + (1 - m->ks.z) * s5);
        return fadd(diffuse, fscale(F, D * G / (4 * nv)));
    }
    default: return zero; /* mirror and glass: their light comes from recursion */
    }
}

/* Exact unpolarised Fresnel reflectance from n1 into n2; *cost gets the
 * cosine of the refracted ray. Total internal reflection: 1. */
static float fresnel(float cosi, float n1, float n2, float *cost)
{
    float eta = n1 / n2;
    float sin2t = eta * eta * (1 - cosi * cosi);
    if (sin2t >= 1) {
        *cost = 0;
        return 1;
    }
    float ct = sqrtf(1 - sin2t);
    *cost = ct;
    float rs = (n1 * cosi - n2 * ct) / (n1 * cosi + n2 * ct);
    float rp = (n1 * ct - n2 * cosi) / (n1 * ct + n2 * cosi);
    return 0.5f * (rs * rs + rp * rp);
}

static fvec trace(const sf_world *w, fvec o, fvec d, int depth)
{
    sf_hit h;
    if (!closest(w, o, d, w->eps, &h))
        return w->background;
    fvec p = fadd(o, fscale(d, h.t));
    fvec ng, ns;
    int mat;
    float u = 0, v = 0;
    if (h.kind == K_SPHERE) {
        const sf_sphere *s = &w->sph[h.idx];
        ng = fscale(fsub(p, s->c), 1.0f / s->r);
        ng = fnormalize(ng);
        ns = ng;
        mat = s->mat;
        u = 0.5f + atan2f(ng.z, ng.x) / (2 * SF_PI);
        v = acosf(fmaxf(-1.0f, fminf(1.0f, ng.y))) / SF_PI;
    } else if (h.kind == K_PLANE) {
        const sf_plane *pl = &w->pl[h.idx];
        ng = ns = pl->n;
        mat = pl->mat;
        fvec rel = fsub(p, pl->q);
        u = fdot(rel, pl->tu);
        v = fdot(rel, pl->tv);
    } else {
        const sf_tri *tr = &w->tri[h.idx];
        float b0 = 1 - h.b1 - h.b2;
        ng = fnormalize(fcross(fsub(tr->v1, tr->v0), fsub(tr->v2, tr->v0)));
        ns = ng;
        if (tr->has_n) {
            fvec n = fadd(fadd(fscale(tr->n0, b0), fscale(tr->n1, h.b1)), fscale(tr->n2, h.b2));
            if (fdot(n, n) > 0)
                ns = fnormalize(n);
        }
        mat = tr->mat;
        u = b0 * tr->uv[0][0] + h.b1 * tr->uv[1][0] + h.b2 * tr->uv[2][0];
        v = b0 * tr->uv[0][1] + h.b1 * tr->uv[1][1] + h.b2 * tr->uv[2][1];
    }
    int front = fdot(ng, d) < 0;
    fvec N = fdot(ns, d) > 0 ? fneg(ns) : ns;
    const sf_mat *m = &w->mats[mat];
    if (m->type == RD_MAT_PSEUDO_NORMAL_COLOR)
        return fv((N.x + 1) * 0.5f, (N.y + 1) * 0.5f, (N.z + 1) * 0.5f);
    fvec kd = m->kd;
    if (m->type == RD_MAT_TEXTURED_PHONG)
        kd = texture_bilinear(m->tex, u * m->uv_scale, v * m->uv_scale);
    int recursive = m->type == RD_MAT_PERFECT_SPECULAR || m->type == RD_MAT_SPECULAR_REFRACTION;
    fvec V = fneg(d);
    fvec color = fv(0, 0, 0);
    unsigned bugs = w->bugs;

    for (size_t li = 0; li < w->nlights; li++) {
        const sf_light *l = &w->lights[li];
        if (bugs & SF_BUG_AMBIENT_PER_LIGHT)
            color = fadd(color, m->ambient);
        if (recursive)
            continue; /* calcReflectedLight is 0 for them */
        int n = l->side * l->side;
        for (int k = 0; k < n; k++) {
            fvec L, to_light, lc = l->color;
            float dist;
            if (l->type == RD_LIGHT_DIRECTIONAL) {
                L = l->dir;
                to_light = fneg(L);
                dist = INFINITY;
            } else {
                fvec at = l->pos;
                if (l->type == RD_LIGHT_AREA) {
                    float a = ((float)(k % l->side) + 0.5f) / (float)l->side;
                    float b = ((float)(k / l->side) + 0.5f) / (float)l->side;
                    at = fadd(l->corner, fadd(fscale(l->e1, a), fscale(l->e2, b)));
                    lc = fscale(lc, 1.0f / (float)n);
                }
                fvec dl = fsub(at, p);
                dist = sqrtf(fdot(dl, dl));
                if (!(dist > 0))
                    continue;
                to_light = fscale(dl, 1.0f / dist);
                L = fneg(to_light);
                if (l->type == RD_LIGHT_SPOT) {
                    float c = fdot(L, l->dir);
                    if (c < l->cos_cut || c <= 0)
                        continue;
                    if (l->falloff != 0)
                        lc = fscale(lc, powf(c, l->falloff));
                }
            }
            if (occluded(w, p, to_light, dist))
                continue;
            fvec incoming = (bugs & SF_BUG_LIGHT_REVERSED) ? to_light : L;
            color = fadd(color, fmulv(lc, calc_reflected_light(m, kd, N, incoming, V, bugs)));
        }
    }
    if (!(bugs & (SF_BUG_NO_AMBIENT | SF_BUG_AMBIENT_PER_LIGHT)))
        color = fadd(color, m->ambient);

    if (!recursive || depth >= w->max_depth)
        return color;
    if (m->type == RD_MAT_PERFECT_SPECULAR) {
        fvec r = freflect(d, N);
        color = fadd(color, fmulv(m->ks, trace(w, p, r, depth + 1)));
    } else {
        float n1 = front ? 1.0f : m->ior, n2 = front ? m->ior : 1.0f;
        float cosi = -fdot(d, N), cost;
        float F = fresnel(cosi, n1, n2, &cost);
        fvec sum = fscale(trace(w, p, freflect(d, N), depth + 1), F);
        if (F < 1) {
            float eta = n1 / n2;
            fvec t = fnormalize(fadd(fscale(d, eta), fscale(N, eta * cosi - cost)));
            sum = fadd(sum, fscale(trace(w, p, t, depth + 1), 1 - F));
        }
        color = fadd(color, fmulv(m->ks, sum));
    }
    return color;
}

/* ---- scene conversion ------------------------------------------------ */

static void world_free(sf_world *w)
{
    free(w->sph);
    free(w->pl);
    free(w->tri);
    free(w->lights);
    free(w->mats);
}

static int world_build(sf_world *w, const rd_scene *s, unsigned bugs, float eps)
{
    memset(w, 0, sizeof *w);
    w->bugs = bugs;
    w->eps = eps;
    w->background = fv_of(s->render.background);
    w->max_depth = s->render.max_depth;
    size_t nsph = 0, npl = 0, ntri = 0;
    for (size_t i = 0; i < s->object_count; i++) {
        const rd_object *o = &s->objects[i];
        if (o->material < 0 || (size_t)o->material >= s->material_count)
            return -1;
        if (o->type == RD_OBJ_SPHERE)
            nsph++;
        else if (o->type == RD_OBJ_PLANE)
            npl++;
        else if (o->type == RD_OBJ_TRIANGLE)
            ntri++;
        else if (o->type == RD_OBJ_MESH) {
            if (o->mesh < 0 || (size_t)o->mesh >= s->mesh_count)
                return -1;
            ntri += s->meshes[o->mesh].nfaces;
        }
    }
    w->sph = calloc(nsph + 1, sizeof *w->sph);
    w->pl = calloc(npl + 1, sizeof *w->pl);
    w->tri = calloc(ntri + 1, sizeof *w->tri);
    w->lights = calloc(s->light_count + 1, sizeof *w->lights);
    w->mats = calloc(s->material_count + 1, sizeof *w->mats);
    if (!w->sph || !w->pl || !w->tri || !w->lights || !w->mats)
        return -1;
    for (size_t i = 0; i < s->material_count; i++) {
        const rd_material *rm = &s->materials[i];
        sf_mat *m = &w->mats[i];
        m->type = rm->type;
        m->kd = fv_of(rm->kd);
        m->ks = fv_of(rm->ks);
        m->ambient = fv_of(rm->ambient);
        m->shininess = (float)rm->shininess;
        m->roughness = (float)rm->roughness;
        m->ior = (float)rm->ior;
        m->uv_scale = (float)rm->uv_scale;
        /* Only textures that some object uses are loaded (scene_assets.h). */
        if (rm->type == RD_MAT_TEXTURED_PHONG && rm->texture_index >= 0 &&
            (size_t)rm->texture_index < s->texture_count) {
            const rd_texture *t = &s->textures[rm->texture_index];
            if (t->width >= 1 && t->height >= 1 && t->rgb)
                m->tex = t;
        }
    }
    for (size_t i = 0; i < s->object_count; i++) {
        const sf_mat *m = &w->mats[s->objects[i].material];
        if (m->type == RD_MAT_TEXTURED_PHONG && !m->tex)
            return -1;
    }
    for (size_t i = 0; i < s->light_count; i++) {
        const rd_light *rl = &s->lights[i];
        sf_light *l = &w->lights[w->nlights++];
        l->type = rl->type;
        l->color = fv_of(rl->color);
        l->pos = fv_of(rl->position);
        l->dir = fnormalize(fv_of(rl->direction));
        l->cos_cut = cosf((float)rl->angle_deg * SF_PI / 180.0f);
        l->falloff = (float)rl->falloff;
        l->corner = fv_of(rl->corner);
        l->e1 = fv_of(rl->edge1);
        l->e2 = fv_of(rl->edge2);
        l->side = rl->type == RD_LIGHT_AREA && rl->samples > 0 ? rl->samples : 1;
    }
    for (size_t i = 0; i < s->object_count; i++) {
        const rd_object *o = &s->objects[i];
        if (o->type == RD_OBJ_SPHERE) {
            sf_sphere *sp = &w->sph[w->nsph++];
            sp->c = fv_of(o->center);
            sp->r = (float)o->radius;
            sp->mat = o->material;
        } else if (o->type == RD_OBJ_PLANE) {
            sf_plane *pl = &w->pl[w->npl++];
            pl->q = fv_of(o->point);
            pl->n = fnormalize(fv_of(o->normal));
            plane_axes(pl);
            pl->mat = o->material;
        } else if (o->type == RD_OBJ_TRIANGLE) {
            sf_tri *t = &w->tri[w->ntri++];
            t->v0 = fv_of(o->v[0]);
            t->v1 = fv_of(o->v[1]);
            t->v2 = fv_of(o->v[2]);
            t->has_n = o->has_normals;
            t->n0 = fv_of(o->n[0]);
            t->n1 = fv_of(o->n[1]);
            t->n2 = fv_of(o->n[2]);
            float def[3][2] = {{0, 0}, {1, 0}, {0, 1}};
            for (int c = 0; c < 3; c++)
                for (int k = 0; k < 2; k++)
                    t->uv[c][k] = o->has_uv ? (float)o->uv[c][k] : def[c][k];
            t->mat = o->material;
        } else if (o->type == RD_OBJ_MESH) {
            const rd_mesh *me = &s->meshes[o->mesh];
            for (size_t f = 0; f < me->nfaces; f++) {
                const rd_mesh_face *fc = &me->faces[f];
                sf_tri *t = &w->tri[w->ntri++];
                t->v0 = fv_of(me->positions[fc->v[0]]);
                t->v1 = fv_of(me->positions[fc->v[1]]);
                t->v2 = fv_of(me->positions[fc->v[2]]);
                t->has_n = fc->n[0] >= 0 && fc->n[1] >= 0 && fc->n[2] >= 0;
                if (t->has_n) {
                    t->n0 = fnormalize(fv_of(me->normals[fc->n[0]]));
                    t->n1 = fnormalize(fv_of(me->normals[fc->n[1]]));
                    t->n2 = fnormalize(fv_of(me->normals[fc->n[2]]));
                }
                int has_t = fc->t[0] >= 0 && fc->t[1] >= 0 && fc->t[2] >= 0;
                float def[3][2] = {{0, 0}, {1, 0}, {0, 1}};
                for (int c = 0; c < 3; c++)
                    for (int k = 0; k < 2; k++)
                        t->uv[c][k] = has_t ? (float)me->uvs[fc->t[c]][k] : def[c][k];
                t->mat = o->material;
            }
        }
    }
    return 0;
}

/* ---- the image ------------------------------------------------------- */

static uint8_t to_byte(float c, float gamma, unsigned bugs)
{
    c = fclamp01(c);
    c = powf(c, 1.0f / gamma);
    if (bugs & SF_BUG_GAMMA_TWICE)
        c = powf(c, 1.0f / gamma);
    return (uint8_t)floorf(c * 255.0f + 0.5f);
}

int sf_render(const rd_scene *s, unsigned bugs, uint8_t **rgb, int *width, int *height)
{
    return sf_render_eps(s, bugs, SF_EPS_DEFAULT, rgb, width, height);
}

int sf_render_eps(const rd_scene *s, unsigned bugs, float eps, uint8_t **rgb, int *width, int *height)
{
    *rgb = NULL;
    int W = s->render.width, H = s->render.height;
    sf_world w;
    memset(&w, 0, sizeof w);
    if (W < 1 || H < 1 || !(eps > 0) || world_build(&w, s, bugs, eps) != 0) {
        world_free(&w);
        return -1;
    }
    uint8_t *out = malloc((size_t)W * (size_t)H * 3);
    if (!out) {
        world_free(&w);
        return -1;
    }
    /* The pinhole camera of shading.md. */
    fvec eye = fv_of(s->camera.eye);
    fvec cw = fnormalize(fsub(eye, fv_of(s->camera.target)));
    fvec cu = fnormalize(fcross(fv_of(s->camera.up), cw));
    fvec cv = fcross(cw, cu);
    float h = tanf((float)s->camera.fov_deg * SF_PI / 360.0f);
    float a = (float)W / (float)H;
    float gamma = (float)s->render.gamma;
    int grid = 1;
    while ((grid + 1) * (grid + 1) <= s->render.samples)
        grid++;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            fvec sum = fv(0, 0, 0);
            for (int j = 0; j < grid; j++)
                for (int i = 0; i < grid; i++) {
                    float px = (float)x + ((float)i + 0.5f) / (float)grid;
                    float py = (float)y + ((float)j + 0.5f) / (float)grid;
                    float sx = (2.0f * px / (float)W - 1.0f) * a * h;
                    float sy = (1.0f - 2.0f * py / (float)H) * h;
                    fvec d = fnormalize(fsub(fadd(fscale(cu, sx), fscale(cv, sy)), cw));
                    sum = fadd(sum, trace(&w, eye, d, 0));
                }
            sum = fscale(sum, 1.0f / (float)(grid * grid));
            uint8_t *o = out + 3 * ((size_t)y * (size_t)W + (size_t)x);
            o[0] = to_byte(sum.x, gamma, bugs);
            o[1] = to_byte(sum.y, gamma, bugs);
            o[2] = to_byte(sum.z, gamma, bugs);
        }
    world_free(&w);
    *rgb = out;
    *width = W;
    *height = H;
    return 0;
}
