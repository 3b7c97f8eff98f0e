#include "trace.h"

#include <float.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fresnel.h"
#include "material.h"
#include "rayd/clock.h"
#include "texture.h"

/* Colour sums saturate here, far above white and far below overflow, so
 * that lights of any finite colour never add up to infinity. */
#define RD_MAX_RADIANCE 1e300

static rd_rgb saturate(rd_rgb c)
{
    double v[3] = {c.x, c.y, c.z};
    for (int i = 0; i < 3; i++)
        v[i] = v[i] > RD_MAX_RADIANCE ? RD_MAX_RADIANCE : (v[i] < -RD_MAX_RADIANCE ? -RD_MAX_RADIANCE : v[i]);
    return v3(v[0], v[1], v[2]);
}

rd_error_code rd_plan_build(rd_plan *p, const rd_scene *s, rd_error *err)
{
    return rd_plan_build_threads(p, s, 1, err);
}

rd_error_code rd_plan_build_threads(rd_plan *p, const rd_scene *s, int threads, rd_error *err)
{
    memset(p, 0, sizeof *p);
    p->scene = s;
    /* The world checks that every object has a material. */
    rd_error_code rc = rd_world_build_threads(&p->world, s, threads, err);
    if (rc)
        return rc;
    for (size_t j = 0; j < s->object_count; j++) {
        const rd_material *m = &s->materials[s->objects[j].material];
        if (m->type == RD_MAT_TEXTURED_PHONG &&
            (m->texture_index < 0 || (size_t)m->texture_index >= s->texture_count)) {
            rd_world_free(&p->world);
            return rd_error_set(err, RD_ERR_INVALID, 0, 0, "material '%s': its texture was not loaded",
                                m->name ? m->name : "?");
        }
    }
    p->lights = calloc(s->light_count + 1, sizeof *p->lights);
    if (!p->lights) {
        rd_world_free(&p->world);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory preparing the lights");
    }
    for (size_t i = 0; i < s->light_count; i++) {
        rd_light_prep lp;
        rd_light_prepare(&lp, &s->lights[i], p->world.origin);
        /* A light that gives nothing costs nothing. */
        if (lp.color.x == 0 && lp.color.y == 0 && lp.color.z == 0)
            continue;
        p->lights[p->nlights++] = lp;
        if (lp.type == RD_LIGHT_AREA)
            p->stochastic = 1;
    }
    for (size_t i = 0; i < s->object_count; i++)
        if (rd_material_is_recursive(&s->materials[s->objects[i].material]))
            p->recursive = 1;
    return RD_OK;
}

void rd_plan_free(rd_plan *p)
{
    rd_world_free(&p->world);
    free(p->lights);
    memset(p, 0, sizeof *p);
}

/* What the shadow rays of one hit share: its origin pushed off the surface
 * to either side, each side computed when the first ray leaves to it (most
 * hits send every ray to one side, many send none). */
typedef struct {
    const rd_hit *h;
    unsigned ready; /* bit s: o[s] and pmax hold their values */
    rd_vec3 o[2];   /* rd_offset_side(h, s) */
    double pmax;    /* v3_max_abs(h->p) */
} shadow_from;

static shadow_from shadow_from_hit(const rd_hit *h)
{
    shadow_from f;
    f.h = h;
    f.ready = 0;
    return f;
}

static rd_vec3 shadow_origin(shadow_from *f, rd_vec3 dir)
{
    int s = rd_offset_below(f->h, dir);
    if (!(f->ready >> s & 1)) {
        f->o[s] = rd_offset_side(f->h, s);
        f->pmax = v3_max_abs(f->h->p);
        f->ready |= 1u << s;
    }
    return f->o[s];
}

/* The shadow ray towards a light sample: 0 when there is none to trace (the
 * light is not blocked), else 1 with the ray and its tmax. Left out of line:
 * forced inline into its two callers it measured no faster. */
static int shadow_ray(shadow_from *f, const rd_light_sample *ls, rd_ray *sr, double *tmax)
{
    const rd_hit *h = f->h;
    sr->o = shadow_origin(f, ls->to_light);
    if (ls->infinite) {
        sr->d = ls->to_light;
        *tmax = INFINITY;
        return 1;
    }
    /* Aim from the pushed-off origin, so the ray still ends at the light. */
    rd_vec3 d = v3_add(ls->to_light, v3_sub(h->p, sr->o));
    double span = v3_max_abs(d);
    if (!(span > 0) || !isfinite(span))
        return 0;
    /* Stop just short of the light: by the rounding error of the two end
     * points, so a light on a surface is not hidden by it while one a hair
     * inside a closed object still is. Relative, so it scales. */
    double end = 1.0 - 64 * DBL_EPSILON * (f->pmax + v3_max_abs(v3_add(h->p, ls->to_light))) / span;
    if (!(end > 0))
        return 0;
    /* A direction of length about 1 (an exact power-of-two rescaling, with
     * tmax scaled back) keeps the sphere test's squares in range for
     * lights and scenes at any scale. The exponent comes from the bits:
     * ilogb and ldexp are library calls on every shadow ray. */
    uint64_t bits;
    memcpy(&bits, &span, sizeof bits);
    int e = (int)((bits >> 52) & 0x7ff) - 1023;
    if (e < -1000 || e > 1000) {
        e = ilogb(span);
        sr->d = v3(ldexp(d.x, -e), ldexp(d.y, -e), ldexp(d.z, -e));
        *tmax = ldexp(end, e);
        return 1;
    }
    double down, up;
    uint64_t b1 = (uint64_t)(1023 - e) << 52, b2 = (uint64_t)(1023 + e) << 52;
    memcpy(&down, &b1, sizeof down);
    memcpy(&up, &b2, sizeof up);
    sr->d = v3_scale(d, down);
    *tmax = end * up;
    return 1;
}

static uint32_t *occluder_of(rd_ray_counts *counts, size_t light)
{
    return light < RD_OCCLUDER_LIGHTS ? &counts->occluder[light] : NULL;
}

static int shadowed(const rd_plan *p, shadow_from *f, const rd_light_sample *ls, size_t light, rd_ray_counts *counts)
{
    rd_ray sr;
    double tmax;
    counts->shadow++;
    return shadow_ray(f, ls, &sr, &tmax) && rd_world_any_hint(&p->world, sr, tmax, occluder_of(counts, light));
}

void rd_counts_init(rd_ray_counts *c, double deadline_ms, const atomic_int *cancel)
{
    memset(c, 0, sizeof *c);
    c->deadline_ms = deadline_ms;
    c->cancel = cancel;
    c->check_every = 256;
    /* Nothing to look at: the countdown never reaches zero. */
    c->until_check = deadline_ms > 0 || cancel ? c->check_every : INT64_MAX;
    c->last_check_ms = c->until_check == INT64_MAX ? 0 : rd_now_ms();
}

int rd_counts_check(rd_ray_counts *c)
{
    if (c->stopped) {
        c->until_check = 1;
        return 1;
    }
    if (!(c->deadline_ms > 0) && !c->cancel) {
        c->until_check = INT64_MAX;
        return 0;
    }
    double now = rd_now_ms();
    if ((c->cancel && atomic_load_explicit(c->cancel, memory_order_relaxed)) ||
        (c->deadline_ms > 0 && now > c->deadline_ms)) {
        c->stopped = 1;
        c->until_check = 1;
        return 1;
    }
    double dt = now - c->last_check_ms;
    if (dt > 2 && c->check_every > 1)
        c->check_every /= 2;
    else if (dt < 0.5 && c->check_every < (1 << 20))
        c->check_every *= 2;
    c->last_check_ms = now;
    c->until_check = c->check_every;
    return 0;
}

static rd_rgb trace_secondary(const rd_plan *p, const rd_hit *h, rd_vec3 dir, int depth, rd_rng *rng,
                              rd_ray_counts *counts)
{
    if (rd_counts_tick(counts))
        return v3(0, 0, 0);
    rd_ray r;
    r.o = rd_offset_origin(h, dir);
    r.d = dir;
    counts->secondary++;
    return rd_trace(p, r, depth + 1, rng, counts);
}

static int is_black(rd_rgb c) { return c.x == 0 && c.y == 0 && c.z == 0; }

/* The light already known to reach a hit or not, for shade(): a packet's
 * shadow rays are traced before its hits are shaded. */
enum { VIS_TRACE = -1, VIS_OPEN = 0, VIS_BLOCKED = 1 };

/* The light from the plan's lights reaching hit h (material m, seen from V),
 * added to *color; 1 when the render must stop. vis as for shade(); from
 * (NULL: one of its own) holds h's shadow-ray origins. Not inlined into
 * shade(): the shadow rays' set-up is inlined here, and in shade() its
 * frame would grow every recursion level's. */
__attribute__((noinline)) static int direct_light(const rd_plan *p, const rd_material *m, const rd_hit *h, rd_vec3 V,
                                                  rd_rng *rng, rd_ray_counts *counts, const signed char *vis,
                                                  shadow_from *from, rd_rgb *color)
{
    shadow_from own = shadow_from_hit(h);
    shadow_from *f = from ? from : &own;
    for (size_t i = 0; i < p->nlights; i++) {
        const rd_light_prep *lp = &p->lights[i];
        for (int k = 0; k < lp->samples; k++) {
            if (rd_counts_tick(counts))
                return 1;
            double ux = 0.5, uy = 0.5;
            if (lp->type == RD_LIGHT_AREA) {
                ux = rd_rng_next(rng);
                uy = rd_rng_next(rng);
            }
            rd_light_sample ls;
            if (!rd_light_sample_at(lp, h->p, k, ux, uy, &ls))
                continue;
            /* A light behind the surface contributes 0: no shadow ray. */
            if (!(-v3_dot(h->n, ls.L) > 0))
                continue;
            int known = vis && i < RD_OCCLUDER_LIGHTS ? vis[i] : VIS_TRACE;
            if (known == VIS_TRACE ? shadowed(p, f, &ls, i, counts) : known == VIS_BLOCKED)
                continue;
            *color = saturate(v3_add(*color, v3_mul(ls.color, rd_calc_reflected_light(m, h, ls.L, V))));
        }
    }
    return 0;
}

/* The colour of r's hit h (its texture coordinates filled in when its
 * material asks for them). vis (NULL: trace every shadow ray here) says, for
 * each of the first RD_OCCLUDER_LIGHTS lights, whether its one sample is
 * blocked, or VIS_TRACE to trace it here; from (may be NULL) holds h's
 * shadow-ray origins, as far as they are known. */
static rd_rgb shade(const rd_plan *p, rd_ray r, rd_hit *h, int depth, rd_rng *rng, rd_ray_counts *counts,
                    const signed char *vis, shadow_from *from)
{
    const rd_scene *s = p->scene;
    const rd_material *m = &s->materials[h->material];
    if (m->type == RD_MAT_PSEUDO_NORMAL_COLOR)
        return v3((h->n.x + 1) * 0.5, (h->n.y + 1) * 0.5, (h->n.z + 1) * 0.5);

    rd_material textured;
    if (m->type == RD_MAT_TEXTURED_PHONG) {
        /* Only textured materials pay for texture coordinates and lookups. */
        rd_world_hit_uv(&p->world, h);
        textured = *m;
        textured.kd = rd_texture_sample(&s->textures[m->texture_index], h->u * m->uv_scale, h->v * m->uv_scale);
        m = &textured;
    }
    rd_rgb color = v3(0, 0, 0);
    if (!rd_material_is_recursive(m) && direct_light(p, m, h, v3_neg(r.d), rng, counts, vis, from, &color))
        return color;
    color = saturate(v3_add(color, m->ambient));

    if (depth >= s->render.max_depth || is_black(m->ks))
        return color;
    if (m->type == RD_MAT_PERFECT_SPECULAR) {
        rd_vec3 d = v3_normalize(v3_reflect(r.d, h->n));
        color = saturate(v3_add(color, v3_mul(m->ks, trace_secondary(p, h, d, depth, rng, counts))));
    } else if (m->type == RD_MAT_SPECULAR_REFRACTION) {
        double n1 = h->front ? 1.0 : m->ior, n2 = h->front ? m->ior : 1.0;
        double cosi = -v3_dot(r.d, h->n), cost;
        double F = rd_fresnel_dielectric(cosi, n1, n2, &cost);
        rd_rgb sum = v3(0, 0, 0);
        if (F > 0) {
            rd_vec3 d = v3_normalize(v3_reflect(r.d, h->n));
            sum = v3_scale(trace_secondary(p, h, d, depth, rng, counts), F);
        }
        if (F < 1) {
            double eta = n1 / n2;
            rd_vec3 t = v3_add(v3_scale(r.d, eta), v3_scale(h->n, eta * rd_clamp01(cosi) - cost));
            t = v3_normalize(t);
            sum = v3_add(sum, v3_scale(trace_secondary(p, h, t, depth, rng, counts), 1 - F));
        }
        color = saturate(v3_add(color, v3_mul(m->ks, saturate(sum))));
    }
    return color;
}

rd_rgb rd_trace(const rd_plan *p, rd_ray r, int depth, rd_rng *rng, rd_ray_counts *counts)
{
    rd_hit h;
    if (!rd_world_closest(&p->world, r, INFINITY, &h))
        return p->scene->render.background;
    return shade(p, r, &h, depth, rng, counts, NULL, NULL);
}

/* Whether shade() gives hit h direct light from the plan's lights. */
static int lit_directly(const rd_plan *p, const rd_hit *h)
{
    const rd_material *m = &p->scene->materials[h->material];
    return m->type != RD_MAT_PSEUDO_NORMAL_COLOR && !rd_material_is_recursive(m);
}

/* The shadow rays of light `light` from the packet's hits, traced as one
 * packet; vis[i][light] gets each ray's answer (or VIS_OPEN where shade()
 * will not ask). Counted as shadowed() counts them. */
static void shadow_packet(const rd_plan *p, const rd_hit *h, shadow_from *from, unsigned lit, size_t light,
                          rd_ray_counts *counts, signed char vis[][RD_OCCLUDER_LIGHTS])
{
    const rd_light_prep *lp = &p->lights[light];
    rd_ray sr[RD_PACKET_MAX];
    double tmax[RD_PACKET_MAX];
    int who[RD_PACKET_MAX], n = 0;
    for (unsigned m = lit; m; m &= m - 1) {
        int i = __builtin_ctz(m);
        vis[i][light] = VIS_OPEN;
        rd_light_sample ls;
        if (!rd_light_sample_at(lp, h[i].p, 0, 0.5, 0.5, &ls) || !(-v3_dot(h[i].n, ls.L) > 0))
            continue;
        counts->shadow++;
        if (shadow_ray(&from[i], &ls, &sr[n], &tmax[n]))
            who[n++] = i;
    }
    unsigned blocked = rd_world_any_packet(&p->world, sr, tmax, n, occluder_of(counts, light));
    for (int k = 0; k < n; k++)
        vis[who[k]][light] = blocked >> k & 1 ? VIS_BLOCKED : VIS_OPEN;
}

void rd_trace_packet(const rd_plan *p, const rd_ray *r, int n, unsigned how, rd_rng *rng, rd_ray_counts *counts,
                     rd_rgb *out)
{
    rd_hit h[RD_PACKET_MAX];
    unsigned found = 0, lit = 0;
    if (how & RD_PACKETS_CAMERA) {
        found = rd_world_closest_packet(&p->world, r, n, INFINITY, h);
    } else {
        for (int i = 0; i < n; i++)
            found |= (unsigned)rd_world_closest(&p->world, r[i], INFINITY, &h[i]) << i;
    }
    signed char vis[RD_PACKET_MAX][RD_OCCLUDER_LIGHTS];
    memset(vis, VIS_TRACE, sizeof vis);
    shadow_from from[RD_PACKET_MAX];
    for (int i = 0; i < n; i++)
        from[i] = shadow_from_hit(&h[i]);
    if (how & RD_PACKETS_SHADOW) {
        for (unsigned m = found; m; m &= m - 1)
            lit |= (unsigned)lit_directly(p, &h[__builtin_ctz(m)]) << __builtin_ctz(m);
        /* An area light's samples are drawn with the hit's random numbers,
         * in shade()'s order: those stay there. */
        for (size_t i = 0; i < p->nlights && i < RD_OCCLUDER_LIGHTS && lit; i++)
            if (p->lights[i].type != RD_LIGHT_AREA)
                shadow_packet(p, h, from, lit, i, counts, vis);
    }
    for (int i = 0; i < n; i++)
        out[i] =
            found >> i & 1 ? shade(p, r[i], &h[i], 0, &rng[i], counts, vis[i], &from[i]) : p->scene->render.background;
}
