/* The true error against a reference render (true_error.h). */
#include "true_error.h"

#include <criterion/criterion.h>
#include <math.h>
#include <stdlib.h>

#include "compare.h"
#include "scene_fixture.h"

double *display_values(const rd_image *img, double gamma)
{
    size_t n = (size_t)img->width * (size_t)img->height * 3;
    double *d = malloc(n * sizeof *d);
    cr_assert(d, "out of memory for %zu display values", n);
    for (size_t i = 0; i < n; i++)
        d[i] = rd_display(img->rgb[i], gamma);
    return d;
}

double rmse_display(const rd_image *img, const double *ref, double gamma)
{
    return rd_compare_display_rmse(img, ref, gamma);
}

double true_error(const rd_image *img, const double *ref, double ref_estimate, double gamma)
{
    double r = rmse_display(img, ref, gamma);
    double t = r * r - ref_estimate * ref_estimate;
    return t > 0 ? sqrt(t) : 0;
}

double *render_reference(rd_scene *s, int samples, rd_render_stats *st)
{
    int keep_samples = s->render.samples;
    uint64_t keep_seed = s->render.seed;
    s->render.samples = samples;
    s->render.seed = keep_seed + 0x5eed;
    rd_render_options o = {0};
    o.threads = 2;
    rd_image ref;
    render_ok(s, &o, &ref, st);
    s->render.samples = keep_samples;
    s->render.seed = keep_seed;
    double *d = display_values(&ref, s->render.gamma);
    rd_image_free(&ref);
    return d;
}
