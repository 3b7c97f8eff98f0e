"""Table 1: the assignment scenes at 1920x1080, rayd against POV-Ray 3.7 on
the hand-written bench/NAME.pov, with each thread count.

rayd and POV-Ray take turns, runs times per configuration; the summary
keeps the best of each figure (noise only ever adds time)."""
import os

from .. import measure

TITLE = "the assignment scenes, rayd against POV-Ray on bench/NAME.pov"
TOOLS = ("povray",)


def run(ctx):
    w, h = ctx.size
    for s in ctx.scenes:
        for f in ("scenes/%s.cfg" % s, "bench/%s.pov" % s):
            if not os.path.isfile(os.path.join(ctx.root, f)):
                raise measure.Failed("%s: missing" % f)
    rows = []
    best = measure.best
    for s in ctx.scenes:
        for t in ctx.threads:
            print("  %s, %d thread(s), %d run(s) ..." % (s, t, ctx.runs), flush=True)
            rr, pr = [], []
            out_r, out_p = ctx.path("%s-t%d-rayd.png" % (s, t)), ctx.path("%s-t%d-povray.png" % (s, t))
            for _ in range(ctx.runs):
                r, st = measure.rayd_render(ctx.rayd, "scenes/%s.cfg" % s, out_r, w, h, t, cwd=ctx.root)
                rr.append(dict(r.record(), stats=measure.stats_record(st)))
                p, pst = measure.povray("bench/%s.pov" % s, out_p, w, h, t, cwd=ctx.root)
                pr.append(dict(p.record(), **pst))
            last = rr[-1]["stats"]
            rows.append({
                "scene": s, "threads": t, "width": w, "height": h, "rayd": rr, "povray": pr,
                "best": {
                    "rayd_wall_ms": best(x["wall_ms"] for x in rr),
                    "rayd_render_ms": best(x["stats"]["time_ms"] for x in rr),
                    "rayd_rays_per_second": best((x["stats"]["rays_per_second"] for x in rr), max),
                    "povray_wall_ms": best(x["wall_ms"] for x in pr),
                    "povray_trace_ms": best(x["trace_ms"] for x in pr),
                },
                "rays_rayd": measure.rays(last),
                "rays_povray": pr[-1]["rays"] + pr[-1]["shadow_tests"],
                "camera_rays": last["camera_rays"], "shadow_rays": last["shadow_rays"],
                "images": measure.compare(ctx.rayd, out_r, out_p),
            })
    return {"settings": {"size": [w, h], "threads": ctx.threads, "scenes": ctx.scenes, "runs": ctx.runs},
            "povray": measure.povray_version(), "povray_overhead_ms": ctx.povray_overhead(), "rows": rows}
