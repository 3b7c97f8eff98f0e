#include "code_cases.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "hash.h"
#include "rayd/memory.h"

static const char *const group_names[] = {
#define RD_CODE_GROUP_NAME(id, word, words) word,
    RD_CODE_GROUPS_X(RD_CODE_GROUP_NAME)
#undef RD_CODE_GROUP_NAME
};
static const char *const group_words[] = {
#define RD_CODE_GROUP_WORDS(id, word, words) words,
    RD_CODE_GROUPS_X(RD_CODE_GROUP_WORDS)
#undef RD_CODE_GROUP_WORDS
};

const char *rd_code_group_name(rd_code_group g) { return (unsigned)g < RD_CODE_GROUPS ? group_names[g] : "?"; }
const char *rd_code_group_words(rd_code_group g) { return (unsigned)g < RD_CODE_GROUPS ? group_words[g] : "?"; }

/* A shininess of the domain: a natural-number assignment gets the nearest
 * natural number, so that its sets keep their spread (1, 8, 32, 101: odd
 * and even) and code that is right only for whole n (a loop power) is
 * judged where the assignment's text says n lies. */
static double in_domain(double shininess, rd_shininess_domain d)
{
    return d == RD_SHININESS_NATURAL ? fmax(1, round(shininess)) : shininess;
}

/* Five parameter sets per type, coloured so that channels differ, with
 * ambient never 0 (a student adding it shows). Shininess 0.5 and 7.5 are
 * fractional where the domain allows (pow of a negative cosine is NaN
 * there), 1 and 101 odd; the stiff sets go to 1e6 and to roughness 0.02. */
#define SETS 5
static rd_material material(rd_material_type t, rd_shininess_domain d, int set, int stiff)
{
    static const double kd[SETS][3] = {
        {0.8, 0.4, 0.2}, {0.2, 0.6, 0.9}, {0.5, 0.5, 0.5}, {0.9, 0.1, 0.3}, {0.05, 0.3, 0.1}};
    static const double ks[SETS][3] = {
        {0.5, 0.45, 0.4}, {0.3, 0.3, 0.3}, {0.9, 0.8, 0.2}, {0.04, 0.2, 0.6}, {0.7, 0.7, 0.7}};
    static const double shininess[SETS] = {0.5, 1, 7.5, 32, 101};
    static const double stiff_shininess[SETS] = {1e3, 1e4, 1e5, 1e6, 3e5};
    static const double roughness[SETS] = {0.1, 0.3, 0.6, 1.0, 0.2};
    static const double stiff_roughness[SETS] = {0.02, 0.05, 0.03, 0.04, 0.025};
    rd_material m;
    memset(&m, 0, sizeof m); /* no name, texture, nor reflect callback */
    rd_material_defaults(&m, t);
    m.kd = v3(kd[set][0], kd[set][1], kd[set][2]);
    m.ks = v3(ks[set][0], ks[set][1], ks[set][2]);
    m.ambient = v3(0.07, 0.05, 0.03);
    m.shininess = in_domain(stiff ? stiff_shininess[set] : shininess[set], d);
    m.roughness = stiff ? stiff_roughness[set] : roughness[set];
    return m;
}

typedef struct {
    rd_code_case *v;
    size_t n, cap;
    uint64_t seed;
    rd_material_type type;
    rd_shininess_domain domain;
} list;

static double uniform(list *l) { return (double)(rd_mix64(++l->seed) >> 11) * 0x1p-53; }

static rd_vec3 on_sphere(list *l)
{
    double z = 2 * uniform(l) - 1, phi = 2 * M_PI * uniform(l), r = sqrt(fmax(0, 1 - z * z));
    return v3(r * cos(phi), r * sin(phi), z);
}

/* A unit direction whose cosine with the unit axis a is in [c0, c1]. */
static rd_vec3 around(list *l, rd_vec3 a, double c0, double c1)
{
    rd_vec3 t = v3_normalize(v3_cross(fabs(a.x) < 0.9 ? v3(1, 0, 0) : v3(0, 1, 0), a));
    rd_vec3 b = v3_cross(a, t);
    double c = c0 + (c1 - c0) * uniform(l), s = sqrt(fmax(0, 1 - c * c)), phi = 2 * M_PI * uniform(l);
    return v3_normalize(v3_add(v3_add(v3_scale(t, s * cos(phi)), v3_scale(b, s * sin(phi))), v3_scale(a, c)));
}

static int add(list *l, rd_code_group g, int stiff, rd_vec3 n, rd_vec3 L, rd_vec3 V, double angle)
{
    if (!rd_grow_array((void **)&l->v, &l->cap, l->n + 1, sizeof *l->v, 512))
        return -1;
    rd_code_case *c = &l->v[l->n];
    memset(c, 0, sizeof *c);
    c->m = material(l->type, l->domain, (int)(l->n % SETS), stiff);
    c->n = n;
    c->L = L;
    c->V = V;
    c->group = g;
    c->angle_deg = angle;
    l->n++;
    return 0;
}

/* The light at a cosine in [c0, c1] with n (negative: behind), the eye in
 * front at one in [v0, v1]. */
static int random_cases(list *l, rd_code_group g, int count, double c0, double c1, double v0, double v1)
{
    for (int i = 0; i < count; i++) {
        rd_vec3 n = on_sphere(l);
        rd_vec3 L = v3_neg(around(l, n, c0, c1));
        if (add(l, g, 0, n, L, around(l, n, v0, v1), 0))
            return -1;
    }
    return 0;
}

/* The eye at the mirror direction (exactly, or within a small angle for
 * the stiff materials), or where the light comes from. */
static int aimed_cases(list *l, rd_code_group g, int count, int stiff)
{
    for (int i = 0; i < count; i++) {
        rd_vec3 n = on_sphere(l);
        rd_vec3 L = v3_neg(around(l, n, 0.1, 1));
        rd_vec3 R = v3_reflect(L, n), V = R;
        if (g == RD_CODE_RETRO)
            V = v3_neg(L);
        if (add(l, g, stiff, n, L, V, 0))
            return -1;
        /* the stiff ones within three widths of the highlight, exp(-n θ²/2) */
        rd_code_case *c = &l->v[l->n - 1];
        if (stiff && i % 4) {
            double width = c->m.type == RD_MAT_COOK_TORRANCE ? c->m.roughness : sqrt(2 / c->m.shininess);
            c->V = around(l, R, cos(3 * width * (i % 4) / 3.0), 1);
            if (v3_dot(c->V, n) <= 0)
                c->V = R;
        }
    }
    return 0;
}

static int normal_incidence(list *l, int count)
{
    for (int i = 0; i < count; i++) {
        rd_vec3 n = on_sphere(l);
        if (add(l, RD_CODE_NORMAL_INCIDENCE, 0, n, v3_neg(n), i == 0 ? n : around(l, n, 0.05, 1), 0))
            return -1;
    }
    return 0;
}

/* The plane of incidence z = 0, n = +y, the light from the left at 0°,
 * 30° and 60°; the eye from -90° (the light's side) to +90°, the mirror
 * at the light's angle. */
static int lobes(list *l)
{
    for (int in = 0; in <= 60; in += 30) {
        double a = in * M_PI / 180;
        rd_vec3 L = v3(sin(a), -cos(a), 0);
        for (int e = -90; e <= 90; e += 2) {
            double t = e * M_PI / 180;
            if (add(l, RD_CODE_LOBE, 0, v3(0, 1, 0), L, v3(sin(t), cos(t), 0), e))
                return -1;
            l->v[l->n - 1].m = material(l->type, l->domain, 3, 0);
            l->v[l->n - 1].incidence_deg = in;
        }
    }
    return 0;
}

rd_error_code rd_code_cases(rd_material_type type, rd_shininess_domain shininess, rd_code_case **cases, size_t *n,
                            rd_error *err)
{
    *cases = NULL;
    *n = 0;
    if (type != RD_MAT_DIFFUSE && type != RD_MAT_PHONG && type != RD_MAT_BLINN_PHONG && type != RD_MAT_COOK_TORRANCE)
        return rd_error_set(err, RD_ERR_UNSUPPORTED, 0, 0, "no configurations for this material type");
    list l = {NULL, 0, 0, 0x636f646563617365ull, type, shininess};
    int bad = random_cases(&l, RD_CODE_GENERAL, 1500, 0.05, 1, 0.05, 1) ||
              random_cases(&l, RD_CODE_BACK_LIT, 300, -1, -0.02, 0.05, 1) ||
              random_cases(&l, RD_CODE_GRAZING, 200, 1e-4, 0.03, 0.05, 1) || aimed_cases(&l, RD_CODE_MIRROR, 200, 0) ||
              normal_incidence(&l, 100) || aimed_cases(&l, RD_CODE_RETRO, 100, 0) ||
              random_cases(&l, RD_CODE_VIEW_GRAZING, 150, 0.05, 1, 1e-4, 0.03) ||
              (type != RD_MAT_DIFFUSE && aimed_cases(&l, RD_CODE_STIFF, 400, 1)) || lobes(&l);
    if (bad) {
        free(l.v);
        return rd_error_set(err, RD_ERR_NOMEM, 0, 0, "out of memory");
    }
    *cases = l.v;
    *n = l.n;
    return RD_OK;
}
