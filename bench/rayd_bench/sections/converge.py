"""Section 8, convergence: `rayd converge` on the soft-shadow scene and on the
anti-aliasing scene, estimated and true error against samples per pixel,
with its SVG plots and CSV tables kept in --out-dir. The figures come from
the CSV; the log-log slopes are fitted here from them, as rayd converge
fits its own."""
import csv
import math
import os

from .. import measure

TITLE = "rayd converge: estimated and true error against samples and time"
TOOLS = ()

SCENES = ("area_light", "phong")


def slope(xs, ys):
    """Least-squares slope of log(y) against log(x) over points with y > 0."""
    pts = [(math.log(x), math.log(y)) for x, y in zip(xs, ys) if x > 0 and y > 0]
    n = len(pts)
    if n < 2:
        return None
    sx = sum(p[0] for p in pts)
    sy = sum(p[1] for p in pts)
    sxx = sum(p[0] * p[0] for p in pts)
    sxy = sum(p[0] * p[1] for p in pts)
    d = n * sxx - sx * sx
    return (n * sxy - sx * sy) / d if d else None


def run(ctx):
    w, h, top, ref = (40, 30, 8, 64) if ctx.quick else (160, 120, 64, 1024)
    os.makedirs(ctx.out_dir, exist_ok=True)
    out = []
    for s in SCENES:
        print("  rayd converge scenes/%s.cfg ..." % s, flush=True)
        svg = os.path.join(ctx.out_dir, "converge-%s.svg" % s)
        csv_path = os.path.join(ctx.out_dir, "converge-%s.csv" % s)
        r = measure.run([ctx.rayd, "converge", "scenes/%s.cfg" % s, "--width", str(w), "--height", str(h),
                         "--max-samples", str(top), "--reference-samples", str(ref), "--threads", str(ctx.cpus),
                         "--svg", svg, "--csv", csv_path], cwd=ctx.root, what="rayd converge")
        with open(csv_path) as f:
            rows = [{k: float(v) for k, v in rec.items()} for rec in csv.DictReader(f)]
        for row in rows:
            row["ratio"] = row["estimate"] / row["true"] if row["true"] > 0 else None
        spp = [x["samples"] for x in rows]
        out.append({"scene": s, "rows": rows, "wall_ms": r.wall_ms,
                    "slope_true": slope(spp, [x["true"] for x in rows]),
                    "slope_estimate": slope(spp, [x["estimate"] for x in rows]),
                    "svg": os.path.relpath(svg, ctx.root), "csv": os.path.relpath(csv_path, ctx.root)})
    return {"settings": {"size": [w, h], "max_samples": top, "reference_samples": ref}, "scenes": out}
