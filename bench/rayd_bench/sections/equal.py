"""Section 9, equal time. Two questions, each renderer measured against a
converged reference of its own (their pixel filters and area-light
profiles differ, so they converge to slightly different images):

 1. adaptive against uniform: two rayd renders of the same scene with the
    same --time-budget-ms, with and without --adaptive (the idea of the
    printed-only "Equal time" measurement of tests/unit/core/test_progressive.c);
 2. against POV-Ray: POV-Ray at three qualities of its adaptive
    anti-aliasing and area lights, and rayd given POV-Ray's render time as
    its budget, uniform and adaptive, plus a plain --samples 4.

rayd's reference is rendered with another seed than the timed renders, so
that their errors are independent. Every RMSE is `rayd compare` of 8-bit
PNGs, in 1 = 255 units."""
import os
import sys

from .. import measure

TITLE = "equal time: adaptive against uniform, and rayd against POV-Ray"
TOOLS = ("povray",)

SCENES = ("area_light", "phong")
REF_SEED = "24301"  # 0x5eed, as the test's reference
CAP = "65536"       # only a cap: the budget decides

# POV-Ray's settings per quality: bench/cfg2pov.py's area-light options
# (points per side, adaptive level), and antialiasing on its command line.
POV_AREA = {"REF": ["--area-size", "9"], "moderate": ["--area-size", "5", "--area-adaptive", "1"],
            "high": ["--area-size", "9", "--area-adaptive", "2"], "higher": ["--area-size", "9", "--area-adaptive", "2"]}
POV_AA = {"REF": ["+AM1", "+A0.0", "+R9", "+J"], "moderate": ["+AM1", "+A0.3", "+R3", "+J"],
          "high": ["+AM1", "+A0.1", "+R3", "+J"], "higher": ["+AM1", "+A0.0", "+R4", "+J"]}
QUICK_REF = (["--area-size", "5"], ["+AM1", "+A0.0", "+R3", "+J"])
LEVELS = ("moderate", "high", "higher")
FIXED = 4


def rayd_timed(ctx, s, tag, extra):
    w, h = ctx.eq_size
    out = ctx.path("eq-%s-%s.png" % (s, tag))
    r, st = measure.rayd_render(ctx.rayd, "scenes/%s.cfg" % s, out, w, h, ctx.eq_threads, extra, cwd=ctx.root)
    return out, dict(r.record(), stats=measure.stats_record(st), rays_per_pixel=measure.rays(st) / (w * h))


def adaptive_vs_uniform(ctx, s, ref, budgets):
    rows = []
    for b in budgets:
        for mode, extra in (("uniform", []), ("adaptive", ["--adaptive"])):
            png, rec = rayd_timed(ctx, s, "%s-%d" % (mode, b), ["--samples", CAP, "--time-budget-ms", str(b)] + extra)
            rec.update(budget_ms=b, mode=mode, vs_reference=measure.compare(ctx.rayd, png, ref))
            rows.append(rec)
    return rows


def against_povray(ctx, s, rref, gen):
    w, h = ctx.eq_size
    py = sys.executable
    pov = {}
    for lvl in ("REF",) + LEVELS:
        area = QUICK_REF[0] if (ctx.quick and lvl == "REF") else POV_AREA[lvl]
        pov[lvl] = os.path.join(gen, "%s-%s.pov" % (s, lvl))
        measure.run([py, "bench/cfg2pov.py", "scenes/%s.cfg" % s, pov[lvl], "--width", str(w), "--height", str(h),
                     "--rayd", ctx.rayd] + area, cwd=ctx.root, what="bench/cfg2pov.py")
    ref_aa = QUICK_REF[1] if ctx.quick else POV_AA["REF"]
    pref = ctx.path("eq-%s-pov-ref.png" % s)
    _, pst = measure.povray(pov["REF"], pref, w, h, ctx.cpus, ref_aa, cwd=ctx.root)
    refs = {"povray": {"trace_ms": pst["trace_ms"], "camera_rays_per_pixel": pst["rays"] / (w * h),
                       "antialiasing": ref_aa, "cfg2pov": QUICK_REF[0] if ctx.quick else POV_AREA["REF"]},
            "rayd_vs_povray": measure.compare(ctx.rayd, rref, pref)}
    rows = []
    for lvl in LEVELS:
        print("  %s %s: povray x%d, rayd at its time ..." % (s, lvl, ctx.runs), flush=True)
        out = ctx.path("eq-%s-pov-%s.png" % (s, lvl))
        runs = []
        for _ in range(ctx.runs):
            p, pst = measure.povray(pov[lvl], out, w, h, ctx.eq_threads, POV_AA[lvl], cwd=ctx.root)
            runs.append(dict(p.record(), **pst))
        best_trace = measure.best(x["trace_ms"] for x in runs)
        last = runs[-1]
        rows.append({"renderer": "povray", "quality": lvl, "runs": runs,
                     "settings": {"cfg2pov": POV_AREA[lvl] if s == "area_light" else [], "antialiasing": POV_AA[lvl]},
                     "wall_ms": measure.best(x["wall_ms"] for x in runs), "render_ms": best_trace,
                     "spp": last["rays"] / (w * h), "rays_per_pixel": (last["rays"] + last["shadow_tests"]) / (w * h),
                     "vs_reference": measure.compare(ctx.rayd, out, pref)})
        budget = max(1, int(best_trace + 0.5))
        for mode, extra in (("uniform", []), ("adaptive", ["--adaptive"])):
            png, rec = rayd_timed(ctx, s, "%s-%s" % (lvl, mode), ["--samples", CAP, "--time-budget-ms", str(budget)] + extra)
            rows.append({"renderer": "rayd", "quality": lvl, "mode": mode, "budget_ms": budget, "run": rec,
                         "wall_ms": rec["wall_ms"], "render_ms": rec["stats"]["time_ms"],
                         "spp": rec["stats"]["mean_samples"], "rays_per_pixel": rec["rays_per_pixel"],
                         "vs_reference": measure.compare(ctx.rayd, png, rref)})
    runs = []
    for _ in range(ctx.runs):
        png, rec = rayd_timed(ctx, s, "fixed", ["--samples", str(FIXED)])
        runs.append(rec)
    rows.append({"renderer": "rayd", "quality": "fixed", "mode": "--samples %d" % FIXED, "runs": runs,
                 "wall_ms": measure.best(x["wall_ms"] for x in runs),
                 "render_ms": measure.best(x["stats"]["time_ms"] for x in runs), "spp": FIXED,
                 "rays_per_pixel": runs[-1]["rays_per_pixel"], "vs_reference": measure.compare(ctx.rayd, png, rref)})
    return refs, rows


def run(ctx):
    w, h = ctx.eq_size
    gen = ctx.path("equal")
    os.makedirs(gen, exist_ok=True)
    budgets = (50, 150) if ctx.quick else (300, 1000)
    out = []
    for s in SCENES:
        print("  %s: rayd's reference (%d samples) ..." % (s, ctx.eq_ref_samples), flush=True)
        rref = ctx.path("eq-%s-rayd-ref.png" % s)
        _, st = measure.rayd_render(ctx.rayd, "scenes/%s.cfg" % s, rref, w, h, ctx.cpus,
                                    ["--samples", str(ctx.eq_ref_samples), "--seed", REF_SEED], cwd=ctx.root)
        ref = {"samples": ctx.eq_ref_samples, "seed": int(REF_SEED), "time_ms": st["time_ms"],
               "error_estimate": st["error_estimate"]}
        print("  %s: adaptive against uniform at %s ms ..." % (s, " and ".join(map(str, budgets))), flush=True)
        avu = adaptive_vs_uniform(ctx, s, rref, budgets)
        refs, rows = against_povray(ctx, s, rref, gen)
        refs["rayd"] = ref
        out.append({"scene": s, "references": refs, "adaptive_vs_uniform": avu, "against_povray": rows})
    return {"settings": {"size": [w, h], "threads": ctx.eq_threads, "reference_samples": ctx.eq_ref_samples,
                         "budgets_ms": list(budgets), "runs": ctx.runs},
            "povray": measure.povray_version(), "povray_overhead_ms": ctx.povray_overhead(), "scenes": out}
