/* The numerical-stability cases, one RD_CASE(...) each: the single list
 * of their names (tests/stability/cases.h describes the fields):
 *
 *   RD_CASE(name, group, scenes, property, unit, tolerance, why_tol,
 *           analysis, run)
 *
 * No include guard: whoever includes this file defines RD_CASE first.
 * cases.c makes the rd_cases table of it, test_stability.c one Criterion
 * test per case, named after the case. */

/* scale */
RD_CASE(scale_pow2, "scale", "scale.cfg",
        "The whole scene scaled about the eye by 2^k, k from -40 to 40 in steps of 5 and k = ±1, renders the same "
        "bytes as at "
        "scale 1.",
        "differing bytes", 0, "powers of two scale every intermediate value exactly (no absolute epsilon anywhere)",
        NULL, run_scale_pow2)
RD_CASE(
    scale_pow2_wide, "scale", "scale.cfg",
    "The same for 2^±60 to 2^±300, where squares of coordinates (spheres) and triple products (triangles) still stay "
    "within double range.",
    "differing bytes", 0, "as scale_pow2",
    "Cause: a shadow ray's direction is the whole hit-to-light vector (core/render/trace.c:71), not a unit vector, and "
    "rd_sphere_intersect forms a = d·d and disc = a·(r - |l|)·(r + |l|) (core/geometry/sphere.c:8, 13), which scale as "
    "|d|²·r² = s⁴. At 2^-300 disc underflows to -0, which `!(disc >= 0)` lets through as a tangent hit, so rays that "
    "miss a sphere report one (false shadows); at 2^300 it overflows (shadows vanish). Camera rays are unit and keep "
    "working. Exact scale invariance therefore holds to about 2^±250 (measured: every k up to ±250 gives the same "
    "bytes). Fix (A): in shadowed(), scale sr.d by the exact power of two 2^-e, e = ilogb(v3_max_abs(sr.d)), and pass "
    "tmax = ldexp(SHADOW_END, e). Every intermediate value of the sphere, plane, triangle and slab tests then scales "
    "exactly, so images do not change by a bit (checked on a private build: all 47 bundled and extreme scenes give the "
    "same bytes, the 102k-triangle mesh scene renders in the same time), and the range grows to about 2^±340, where "
    "the triangle test's triple products leave double range. The same fix makes light_far_extreme pass.",
    run_scale_pow2_wide)
RD_CASE(
    scale_decimal, "scale", "scale.cfg",
    "Scaled by 1e-9, 1e9, 0.1 and 3 (not powers of two), the scene renders as at scale 1 up to a few pixels.",
    "differing pixels (worst scale)", 2,
    "each decimal input times 1e9 is rounded (relative 2^-53), so positions move by about 1e-16 of their size: a "
    "pixel can change only where a centre ray passes within ~1e-15 of an edge or a value lies within ~1e-13 of a level "
    "boundary, expected well under one pixel per image",
    NULL, run_scale_decimal)
RD_CASE(
    translate_far, "scale", "scale.cfg",
    "Translated with the eye by about 1e6 and 1e8, the scene renders as at the origin up to a few pixels.",
    "differing pixels (worst translation)", 2,
    "rendering is camera-relative, so only the rounding of the translated inputs (ulp(1e8) = 1.5e-8, relative 1.5e-9 "
    "of the scene) can move an edge or a shade: expected well under one pixel",
    NULL, run_translate_far)
RD_CASE(scale_acne, "scale", "scale.cfg",
        "No acne on the glancing lit floor: no isolated dark floor pixel at scale 1, and no floor pixel darker by more "
        "than "
        "1 level than at scale 1 after any of the scalings and translations.",
        "acne pixels", 0, "acne is a shadow ray hitting its own surface: any such pixel is a failure", NULL,
        run_scale_acne)
/* geometry */
RD_CASE(
    tiny_far_spheres, "geometry", "tiny_far.cfg",
    "Spheres with radius/distance 1e-4, 1e-8 and 1e-12 cover exactly the pixels whose centre ray meets the true sphere "
    "(long double).",
    "mismatched pixels", 0,
    "boundary pixels, whose ray passes within 64·ε·(|c|+r) of the silhouette (what double inputs resolve), may go "
    "either way and are not counted",
    NULL, run_tiny_far)
RD_CASE(huge_near_sphere, "geometry", "huge_near.cfg",
        "A sphere of radius 1e6, 1e9 or 1e12 seen from 1 above its surface towards the horizon covers the right pixels "
        "and is shaded as in long double.",
        "mismatched pixels", 0, "as tiny_far_spheres; shading within 1 level", NULL, run_huge_near)
RD_CASE(
    planet_as_plane, "geometry", "planet.cfg",
    "A sphere of radius 1e7 whose top is under the camera renders like the plane y = 0 with the same material.",
    "max level difference", 1,
    "the sphere drops below the plane by d²/2R (< 0.01 at the far visible ground) and its normal tilts by d/R < 1e-5: "
    "under half a level; rounding of a value can still cross a level boundary",
    NULL, run_planet_plane)
RD_CASE(
    grazing_light, "geometry", "grazing.cfg",
    "Under a light at 1 degree elevation (directional and point, two views), every lit pixel is lit and the sphere's "
    "shadow starts at its contact point: no acne, no detached shadow (long-double reference).",
    "mismatched pixels", 0,
    "pixels near a silhouette, shadow edge or terminator within the double-precision band are not compared; all "
    "others within 1 level",
    NULL, run_grazing_light)
RD_CASE(camera_inside_sphere, "geometry", "inside.cfg",
        "With the eye inside a closed sphere (centre, 1e-6 and 1e-12 from the wall, off centre), the inside is seen "
        "and lit "
        "as in long double, with no NaN.",
        "mismatched pixels", 0, "as grazing_light", NULL, run_camera_inside)
RD_CASE(
    camera_on_surface, "geometry", "on_surface.cfg on_sphere.cfg",
    "An eye lying exactly on a plane sees it edge on (no pixel shows it) and an eye exactly on a sphere sees its far "
    "inside wall below the tangent and the outside above it.",
    "mismatched pixels", 0, "a ray never hits the surface it starts on (shading.md)", NULL, run_camera_on_surface)
RD_CASE(rays_parallel, "geometry", "parallel.cfg",
        "Rays exactly parallel to the floor (the middle row) and triangles lying in the eye's plane (BVH boxes of zero "
        "height) give the long-double image: parallel rays miss, edge-on triangles cover nothing.",
        "mismatched pixels", 0, "as grazing_light", NULL, run_rays_parallel)
/* triangles */
RD_CASE(tri_watertight, "triangles", "watertight.cfg icosphere.obj ico0.obj",
        "From inside a closed mesh every pixel hits a triangle, with centre rays through vertices, edge midpoints and "
        "face centres, from five eyes.",
        "background pixels", 0, "Woop, Benthin & Wald's test is watertight: a ray through a shared edge or vertex hits",
        NULL, run_tri_watertight)
RD_CASE(
    tri_degenerate, "triangles", "tri_degenerate.cfg",
    "Zero-area triangles are never hit and duplicated ones change nothing (same bytes without them, BVH and plain "
    "loop), and needles 1e-9 and 1e-12 wide render as in long double.",
    "differing bytes + mismatched pixels", 0, "exact: removal must not change a byte",
    "Cause: rd_tri_intersect (core/geometry/triangle.c:31-38) decides inside/outside from the signs of U, V, W. When "
    "the ray "
    "lies, up to rounding, in the plane of the triangle, the sheared 2D corners are collinear with the origin and "
    "U, V, W are pure rounding noise; the sign test (line 34) accepts U = W = 0, V > 0, and det = V != 0 passes "
    "line 37. The zero-area guard (line 61) only catches corners that are exactly collinear. So the sliver with "
    "decimal corners 0.1 0.2 -3.3, 0.2 0.4 -3.6, 0.3 0.6 -3.9 (collinear in decimal, a 1e-17-wide sliver in binary) "
    "is reported hit by the camera rays of pixels (30,27) and (24,39), which lie in the plane through the eye and "
    "its line (x = y/2), at t = 3.61 and 3.87, i.e. at points like (-0.13, -0.25, -3.6), far from the triangle "
    "(barycentrics 0, 1, 0). The BVH hides this: its box test culls those rays. The plain loop (8 or fewer bounded "
    "primitives) and rd_world_any (shadow rays) do not. A triangle seen exactly edge-on can do the same. Fix (B): "
    "after det is formed, return 0 when |det| <= 8·ε·(|Cx·By| + |Cy·Bx| + |Ax·Cy| + |Ay·Cx| + |Bx·Ay| + |By·Ax|). "
    "The projected triangle is then below rounding, so U, V, W mean nothing. A ray through a vertex or an edge of a "
    "triangle it does face has |det| far above that bound, so watertightness is kept. Checked on a private build: "
    "tri_degenerate and tri_watertight pass, all 47 scenes give the same bytes, and the mesh scene renders in the "
    "same time.",
    run_tri_degenerate)
RD_CASE(tri_flat_bvh, "triangles", "flat_bvh.cfg grid.obj",
        "A grid of 128 axis-aligned flat triangles seen straight down along grid lines (zero direction components, "
        "zero-height boxes) and at a grazing angle renders as in long double and, from above, like the plane y = 0.",
        "mismatched pixels + holes", 0, "a hole (background) or a pixel off by more than 1 level is a failure", NULL,
        run_tri_flat_bvh)
RD_CASE(tri_cancel_normals, "triangles", "cancel_normals.cfg cancel.obj",
        "Vertex normals that cancel give no NaN, the interpolated normal where it is defined, and the geometric normal "
        "where it is exactly zero.",
        "mismatched pixels", 0,
        "normals within 1 level of their long-double value, except where the sum is within 1e-9 "
        "of zero (undefined)",
        NULL, run_tri_cancel_normals)
/* materials */
RD_CASE(
    shininess_lobe, "materials", "(calls rd_calc_reflected_light)",
    "Phong and Blinn-Phong at shininess 0, 1, 1e3, 1e6, 1e9 give kd·cos α + ks at the mirror direction and ks·cos(θ)^n "
    "(long double) at small angles θ.",
    "relative error", 1e-6, "pow via exp(n·log1p(-|a-b|²/2)): the argument's error is ~ε·n·|a-b|² ≲ 1e-7 at n = 1e9",
    NULL, run_shininess_lobe)
RD_CASE(
    highlight_disc, "materials", "highlight.cfg",
    "A highlight of shininess 1e3, 1e6 and 1e9 (Phong and Blinn) on a sphere, zoomed to fill the image, is the smooth "
    "long-double lobe: every pixel within 1 level, and as many distinct levels across it as the long-double lobe has "
    "(at most one fewer).",
    "mismatched pixels", 0, "a quantised lobe (a few cosines below 1) would show few levels and large errors", NULL,
    run_highlight_disc)
RD_CASE(
    cook_torrance_limits, "materials", "(calls rd_calc_reflected_light)",
    "Cook-Torrance with roughness 1e-4 to 1 and N·V from 1 down to 1e-300 and 0, at and off the mirror configuration, "
    "is finite, non-negative and equal to the long-double formula (with the renderer's 1e200 cap).",
    "relative error", 1e-6, "the Beckmann exponent takes 1 - (N·H)², which cancels: error ε/m², 2e-8 at m = 1e-4", NULL,
    run_cook_torrance_limits)
RD_CASE(
    cook_torrance_lobe, "materials", "(calls rd_calc_reflected_light)",
    "The Beckmann lobe of roughness 1e-5 down to 1e-8 (allowed: roughness is in (0, 1]) keeps its long-double shape "
    "to a relative 1e-6, as Phong's does at shininess 1e9.",
    "relative error", 1e-6, "as shininess_lobe",
    "Cause: the Beckmann exponent is -(1 - nh²)/(nh²·m²) (core/shading/material_cook_torrance.c:14), and 1 - nh² "
    "cancels "
    "near the peak. Its absolute error of about ε becomes an exponent error of ε/m²: 2.2e-6 relative at roughness "
    "1e-5, 1.2e-4 at 1e-6, 2.3e-2 at 1e-7, and a factor e (1.72) at 1e-8. The format allows any roughness in (0, 1]. "
    "This is the cancellation that rd_pow_cos avoids for Phong. Fix (C): pass N and H to beckmann() and use "
    "1 - nh² = x·(2 - x) with x = |N - H|²/2 (exact for unit vectors, as in pow_cos.c). Checked on a private build: "
    "relative error 3e-16 at every roughness, same bytes on all scenes.",
    run_cook_torrance_lobe)
RD_CASE(cook_torrance_image, "materials", "ct_grazing.cfg",
        "A Cook-Torrance sphere and floor with roughness 1e-4, 1e-2 and 1, lit from behind so the mirror configuration "
        "meets N·V -> 0 at the rim, render as in long double with no NaN.",
        "mismatched pixels", 0, "as grazing_light", NULL, run_cook_torrance_image)
RD_CASE(blinn_degenerate_h, "materials", "(calls rd_calc_reflected_light)",
        "Blinn-Phong with L = -V gives kd·(N·V) + ks·(N·V)^n; with L = V (light behind) it gives 0, and with L within "
        "1e-300 of V a finite value.",
        "relative error", 1e-9,
        "H = normalize(2V) is V up to an ulp, so the value is exact to a few ulps; relative error, with an absolute "
        "floor of 1e-9 below which no image can tell",
        NULL, run_blinn_degenerate_h)
RD_CASE(
    fresnel_critical, "materials", "(calls rd_fresnel_dielectric)",
    "Swept across the critical angle (densely within 1e-9 of it), the Fresnel reflectance equals the long-double one, "
    "R + T = 1 with T from the transmission amplitudes at the returned cos θt, and R = 1 exactly past it.",
    "absolute error", 1e-7,
    "near the critical angle cos θt = sqrt(cos² θt) turns the ε rounding of cos² θt into sqrt(ε) = 1.5e-8", NULL,
    run_fresnel_critical)
RD_CASE(
    glass_ior1, "materials", "glass_ior1.cfg",
    "A glass sphere of ior 1 and tint 1 is invisible under ambient-only lighting: the image equals the one without it.",
    "differing pixels", 0,
    "F = 0 and the refracted direction is the incident one; only a backdrop edge within ~1e-15 of a ray could move",
    NULL, run_glass_ior1)
RD_CASE(
    cos_above_one, "materials", "(calls the materials, rd_pow_cos, Fresnel, spot lights)",
    "With unit vectors whose dot product rounds to 1 + 2^-52, every material, pow_cos, Fresnel and the spot factor "
    "give their value at cos = 1 (no NaN, nothing above it).",
    "relative error", 1e-15, "clamping to [0, 1]: a few ulps at most",
    "Cause: rd_pow_cos takes log1p(-x) with x = |a - b|²/2 (core/shading/pow_cos.c:13-16). That form is exact near the "
    "peak (x -> 0), which is what it is for. Far from the peak, x -> 1 and 1 - x = cos is recovered with absolute "
    "error ε, i.e. relative ε/cos: 5e-9 at N·V = 1e-8 with n = 1. For a large n the error is n times that, on values "
    "that are already tiny. No image changes (the absolute error is about 5e-17), but the function is not accurate "
    "to its stated relative tolerance. Fix (D): when x > 1/2 (cos < 1/2, where a·b has no cancellation), return "
    "exp(n·log(a·b)). Checked: error 1.4e-15, same bytes on all scenes.",
    run_cos_above_one)
/* lights */
RD_CASE(
    light_inside_closed, "lights", "light_inside.cfg",
    "A point light inside a closed sphere (at its centre, and 0.5, 1e-3, 1e-6 below its surface) lights nothing "
    "outside: the image equals the one without the light.",
    "lit pixels", 0, "exact: any lit pixel is light leaking through the shell",
    "Cause: cos²θt = (1 - η²) + η²·cos²θi (core/shading/fresnel.c:16) cancels to about 0 near the critical angle, with "
    "an "
    "absolute rounding error of about ε. The square root turns that into sqrt(ε) = 1.5e-8 in cos θt, and "
    "∂F/∂cos θt of about 6-8 there gives |F - F_exact| up to 1.24e-7 for the double input. R + T = 1 holds to 5e-16 "
    "at the returned cos θt, and R = 1 exactly past the critical angle. So this is precision, not energy "
    "conservation: a pixel moves by 3e-5 of a level at most. Fix (E): evaluate cos²θt as "
    "1 - η²·(1 - cos²θi) in long double (one line, refraction only). Checked: error 4.9e-16, same bytes on all "
    "scenes.",
    run_light_inside_closed)
RD_CASE(
    light_inside_near_shell, "lights", "light_inside.cfg",
    "A point light 1e-9 and 1e-10 below the inner surface of a closed sphere of radius 1 lights nothing outside.",
    "lit pixels", 0, "as light_inside_closed",
    "Cause: by design a shadow ray stops 2^-30 (9.3e-10) of its length short of a point light (SHADOW_END, "
    "core/render/trace.c:13, 72), so that the surface holding a light (light_on_surface) does not shadow the points it "
    "faces. The same margin lets a light that is less than 2^-30·|segment| inside a closed object shine through "
    "the object's wall: at 1e-9 below the inner surface of a radius-1 sphere, 463 floor and ball pixels are lit "
    "(up to 120 levels), and at 1e-12, 791 pixels. The light sitting straight up, whose segments cross the shell "
    "far from it, leaks nothing. Fix (G): make the margin the light's own rounding instead of a fixed fraction: "
    "end the ray at 1 - 64·ε·(max|p| + max|light|)/max|to_light| (in camera-relative coordinates; relative, so "
    "scale invariance is kept). Checked on a private build: light_on_surface still passes, the 1e-9 case no longer "
    "leaks, and at 1e-12 (about 600 ulps of the coordinates, at the limit of what doubles resolve) 9 pixels remain "
    "lit by 1 level. Side effect: inlined into rd_trace, it grows the recursion frame from 976 to 1032 bytes, over "
    "stack_depth's 1 KiB, so keep shadowed() out of line (__attribute__((noinline))).",
    run_light_inside_near_shell)
RD_CASE(
    light_on_surface, "lights", "light_on_surface.cfg",
    "Point lights lying exactly on a plane and on a sphere light what they face and are not shadowed by the surface "
    "holding them (the shadow ray stops 2^-30 of its length short of the light): long-double reference.",
    "mismatched pixels", 0, "as grazing_light", NULL, run_light_on_surface)
RD_CASE(light_far_point, "lights", "far_light.cfg",
        "A point light 1e15 away renders like the directional light it tends to.", "max level difference", 1,
        "the light's direction varies by 1e-14 rad over the scene; rounding may cross a level", NULL,
        run_light_far_point)
RD_CASE(
    light_far_extreme, "lights", "far_light.cfg",
    "The same for point lights 1e100 to 1e300 away (positions are any finite numbers).", "max level difference", 1,
    "as light_far_point",
    "Cause: as in scale_pow2_wide. The shadow ray's direction is the hit-to-light vector (core/render/trace.c:71), and "
    "rd_sphere_intersect squares it (a = d·d, core/geometry/sphere.c:8). Past |to_light| = 1.34e154, a is infinite, "
    "disc is "
    "±inf or NaN, and no sphere is ever hit, so spheres stop casting shadows. Measured: the same image as the "
    "directional light up to 9.4e152, and 34 pixels up to 152 levels too bright from 9.4e154 on. Planes and "
    "triangles are unaffected. Fix (A) of scale_pow2_wide (a power-of-two normalised shadow direction) fixes it: "
    "checked, 0 levels up to 9.4e299.",
    run_light_far_extreme)
RD_CASE(
    light_intensity_1e38, "lights", "intense.cfg",
    "Lights of colour 1e38 on diffuse, Phong and Cook-Torrance surfaces give finite values: lit pixels clamp to 255, "
    "shadowed ones show the ambient term (long-double reference).",
    "mismatched pixels", 0, "as grazing_light", NULL, run_light_intensity)
RD_CASE(
    light_intensity_overflow, "lights", "overflow.cfg",
    "Colours of ±1e308 and a mirror of ks 1e10 at depth 64 (all valid input) still give no NaN or infinite sample "
    "(shading.md: never, whatever the scene).",
    "non-finite samples", 0, "shading.md allows none",
    "Cause: the radiance sums in rd_trace (core/render/trace.c:125 per light, :135 mirror, :151 glass) are unbounded. "
    "Two "
    "lights of 1e308 sum to inf, Cook-Torrance's capped 1e200 times a colour of 1e308 is inf, a mirror of ks 1e10 "
    "after 64 bounces is inf, and a light of -1e308 then gives inf - inf = NaN. 1566 samples (every pixel of the "
    "48x32 image and more) were non-finite. job.c's finite_or_zero (core/render/job.c:164) replaces them and counts "
    "them in "
    "stats.nonfinite, so the PNG is right, but shading.md promises no NaN or infinite value whatever the scene, and "
    "the scene format accepts these colours (any finite number). Fix (F): saturate each term and each sum to "
    "±1e300 in rd_trace (a clamp after the products at lines 125, 135 and 151 and after each addition). Display "
    "values cannot change, since anything above 1 shows as 255. At most lights·samples² terms of 1e300 are added, "
    "which stays finite. Checked: 0 non-finite samples, same bytes on all 47 scenes, overflow.cfg included.",
    run_light_overflow)
RD_CASE(light_zero, "lights", "zero_light.cfg",
        "Lights of colour 0 (every type) send no shadow ray and the image equals the unlit one.",
        "shadow rays + differing bytes", 0, "exact", NULL, run_light_zero)
RD_CASE(area_light_zero_area, "lights", "area_zero.cfg",
        "An area light with both edges 0 renders like a point light at its corner.", "max level difference", 1,
        "16 samples of colour/16 are summed in floating point, where the point light multiplies once: the sums round "
        "differently by a few ulps",
        NULL, run_area_zero)
/* recursion */
RD_CASE(
    mirror_series, "recursion", "mirrors.cfg",
    "Between two facing mirrors at max_depth 64 every pixel equals ambient·(1 + ks + ... + ks^64), and rays parallel "
    "to the mirrors show the background.",
    "relative error", 1e-12, "65 additions and multiplications in double: ~65 ulps", NULL, run_mirror_series)
RD_CASE(mirror_rays_linear, "recursion", "mirrors.cfg",
        "Between the mirrors the secondary rays are exactly (bouncing pixels)·max_depth for depth 0 to 64: linear in "
        "depth.",
        "rays off the count", 0, "exact count", NULL, run_mirror_rays_linear)
RD_CASE(
    stack_depth, "recursion", "mirrors.cfg",
    "Recursion to depth 64 uses a bounded stack: trace() nests at most max_depth deep, each level a fixed frame "
    "(measured on a painted thread stack) of at most " STACK_NOTE ", under 256 KiB in all.",
    "bytes per level", STACK_FRAME_MAX,
    "rd_trace -> trace_secondary -> rd_trace holds an rd_hit, a textured-material copy and a few vectors per level "
    "(nothing else recurses: the BVH walk uses a fixed 128-entry array); 64 levels of 2 KiB are 128 KiB, far inside "
    "a default 8 MiB thread stack",
    NULL, run_stack_depth)
RD_CASE(
    glass_rays_linear, "recursion", "glass_sheets.cfg",
    "Between three glass sheets the rays per camera ray grow no faster than the binary Whitted tree shading.md "
    "prescribes (both the reflected and the refracted ray at every glass hit): doubling max_depth from 8 to 16 "
    "multiplies them by at most 2^8; a render's deadline (the daemon's --job-timeout-ms) bounds the time.",
    "growth of rays from depth 8 to 16", 256,
    "the spec's exact formula makes the tree binary; pruning it would change graded images, so the bound is the "
    "tree itself and the time is bounded by the deadline checked inside deep recursion",
    "Cause: a specular_refraction hit that is not total internal reflection traces both the reflected and the "
    "refracted ray (core/render/trace.c:141-150), so between several glass surfaces the ray tree is binary. Measured: "
    "50.6 "
    "secondary rays per camera ray at depth 8, 510 at depth 16 (x1.33 per level). At that rate depth 64, which the "
    "format allows (--limit-depth defaults to 64), needs about 5e8 rays per camera ray: a small image of three glass "
    "planes keeps a daemon worker busy for days. Mirrors are linear (mirror_rays_linear). Fix (H), prototype: carry "
    "the path's weight (the product of ks·F or ks·(1 - F) factors) down the recursion and skip a branch whose weight "
    "falls below 2^-12. With ks <= 1 the weights at one depth sum to at most 1, so at most 4096 branches per level "
    "survive, and the rays grow linearly. Measured on a private build: 20.9 rays per camera ray at every depth from "
    "12 on. It changes glass images where a pruned branch would have added at least half a level: 297 bytes by 1 "
    "level in specular_refraction.cfg, but up to 11 levels in extreme/order.cfg, where a pruned path reaches a "
    "Cook-Torrance rim of radiance far above 1. The alternatives are a per-camera-ray budget of secondary rays "
    "(beyond it, follow only the heavier branch) or a documented cost limit on depth times glass surfaces.",
    run_glass_rays)
/* camera */
RD_CASE(camera_fov_tiny, "camera", "camera.cfg",
        "A field of view of 1e-6 degrees on a sphere's silhouette renders as in long double.", "mismatched pixels", 0,
        "as grazing_light", NULL, run_camera_fov_tiny)
RD_CASE(camera_fov_wide, "camera", "camera.cfg", "A field of view of 179.999 degrees renders as in long double.",
        "mismatched pixels", 0, "as grazing_light", NULL, run_camera_fov_wide)
RD_CASE(camera_1x1, "camera", "camera.cfg", "A 1x1 image is its centre ray's long-double value.", "mismatched pixels",
        0, "as grazing_light", NULL, run_camera_1x1)
RD_CASE(camera_strips, "camera", "camera.cfg",
        "1x4096 and 4096x1 images (aspect 1/4096 and 4096) render as in long double.", "mismatched pixels", 0,
        "as grazing_light", NULL, run_camera_strips)
/* order */
RD_CASE(same_sphere_twice, "order", "order.cfg",
        "Every sphere and triangle given twice (BVH and plain loop) renders the same bytes.", "differing bytes", 0,
        "a copy at the same t with the same material changes nothing", NULL, run_same_sphere_twice)
RD_CASE(shuffled_order, "order", "order.cfg",
        "Objects in reversed and shuffled order (BVH and plain loop) render the same bytes.", "differing bytes", 0,
        "the closest hit does not depend on the order of the objects", NULL, run_shuffled_order)
