"""Rays per second against the number of primitives: the same bumpy sphere
(scenes/gen.py bumpy) tessellated into 10^2 to 10^6 flat triangles, on a
floor of two triangles, at 1920x1080 on 1 thread; rayd against Embree's
single-ray mode on the same rays (bench/embree_trace). The shape, and so
the image and the number of rays, barely change with the count: what
changes is the cost of finding the hit. The summary is the cost of a ray at
the largest count over the smallest (the target for rayd: at most 3x)."""
import os

from .. import measure
from . import embree

TITLE = "rays/s against the number of triangles, rayd and Embree single-ray, 1 thread"
TOOLS = ()

# triangles -> scenes/gen.py bumpy SEGS RINGS, 2 * SEGS * (RINGS - 1) = triangles
GRIDS = {100: (10, 6), 1000: (25, 21), 10000: (100, 51), 100000: (250, 201), 1000000: (1000, 501)}
QUICK = (100, 1000, 10000)
TARGET = 3.0


def run(ctx):
    gen = ctx.path("gen-primitives")
    os.makedirs(gen, exist_ok=True)
    embree.harness(ctx)
    counts = [n for n in ctx.prim_counts if not ctx.quick or n in QUICK]
    t = 1
    rows = []
    for n in counts:
        segs, rings = GRIDS[n]
        print("  %s triangles, %d thread, %d run(s) ..." % ("{:,}".format(n), t, ctx.runs), flush=True)
        scene, tris = embree.bumpy(ctx, gen, "bumpy%d" % n, segs, rings)
        row = embree.compare_one(ctx, "bumpy%d" % n, scene, tris + 2, t, ("single",))
        row.update(triangles=tris, grid=[segs, rings])
        rows.append(row)
        # The large OBJ files are not needed once measured.
        for ext in (() if ctx.keep else (".obj", ".cfg")):
            try:
                os.unlink(scene[:-4] + ext)
            except OSError:
                pass
    w, h = ctx.size
    return {"settings": {"size": [w, h], "threads": t, "runs": ctx.runs, "counts": counts, "target": TARGET},
            "rows": rows}
