"""rayd against Embree 3 on the same rays: three scenes generated at bench
time (three spheres, 10,000 spheres, a 1,000,000-triangle bumpy sphere), all
on a floor of two triangles, at 1920x1080 with 1 and 2 threads.

rayd renders with `--samples 1` (one ray through each pixel centre, and a
shadow ray per light from each hit); bench/embree_trace reads the same scene
through rayd's own loader and traces the same camera and shadow rays with
Embree, one ray at a time (rtcIntersect1/rtcOccluded1) and in 16-wide
packets (rtcIntersect16/rtcOccluded16). They take turns, runs times per
configuration, and the best of each figure is kept. rayd's rate is its camera
+ shadow rays over its render time without the BVH build (time_ms -
prepare_ms), as in the large section; Embree's is the same rays over its
trace time, its build (rtcCommitScene, one thread) timed apart. The driver
checks that both count the same rays and that Embree's two modes agree.

rayd also renders each scene with `--packets all` (4x4 pixel blocks traced
as packets of camera rays and of shadow rays; the same image and counts),
taking its turn with the others, so that its packets are measured against
its own ray-by-ray walk and against Embree's 16-wide packets."""
import json
import math
import os
import sys

from .. import measure

TITLE = "rayd against Embree 3 on the same camera and shadow rays"
TOOLS = ()

# scenes/gen.py arguments: full size, and --quick.
SPHERES = {False: 10000, True: 500}
BUMPY = {False: (1000, 501), True: (50, 21)}
# A million triangles and the floor are over rayd's default limit.
MAX_OBJECTS = ["--limit-objects", "2000000"]
# Half the side of the two-triangle floor that replaces a plane.
FLOOR_HALF = 200.0


def harness(ctx):
    h = ctx.embree_trace
    if not (os.path.isfile(h) and os.access(h, os.X_OK)):
        raise measure.Failed("%s: not built (make build/bench/embree_trace; make bench builds it)" % h)
    return h


def floor_triangles(plane, half=FLOOR_HALF):
    """A plane object of a rayd JSON scene as two triangle objects: a square
    of side 2*half about its point, counter-clockwise seen from its normal."""
    n = plane.get("normal", [0, 1, 0])
    ln = math.sqrt(sum(x * x for x in n))
    n = [x / ln for x in n]
    a = [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0]

    def cross(p, q):
        return [p[1] * q[2] - p[2] * q[1], p[2] * q[0] - p[0] * q[2], p[0] * q[1] - p[1] * q[0]]

    u = cross(n, a)
    lu = math.sqrt(sum(x * x for x in u))
    u = [x / lu for x in u]
    v = cross(n, u)
    p0 = plane.get("point", [0, 0, 0])
    c = [[p0[k] + half * (su * u[k] + sv * v[k]) for k in range(3)] for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    tris = []
    for i, j, k in ((0, 1, 2), (0, 2, 3)):
        t = {"type": "triangle", "v0": c[i], "v1": c[j], "v2": c[k]}
        for key in ("material", "name"):
            if key in plane:
                t[key] = plane[key] + ("-%d" % len(tris) if key == "name" else "")
        tris.append(t)
    return tris


def with_triangle_floor(ctx, src, dst):
    """src (cfg or JSON) written by `rayd convert` as JSON to dst, every plane
    replaced by two triangles (floor_triangles). Returns the number of planes."""
    r = measure.run([ctx.rayd, "convert", src, "-", "--to", "json"], cwd=ctx.root, what="rayd convert")
    doc = json.loads(r.stdout)
    objs, planes = [], 0
    for o in doc["objects"]:
        if o["type"] == "plane":
            objs += floor_triangles(o)
            planes += 1
        else:
            objs.append(o)
    doc["objects"] = objs
    with open(dst, "w") as f:
        json.dump(doc, f, indent=1)
    return planes


def bumpy(ctx, gen, name, segs, rings):
    """scenes/gen.py bumpy: gen/NAME.cfg and gen/NAME.obj; returns the cfg
    and its triangle count (the sphere's; the floor adds 2)."""
    cfg = os.path.join(gen, name + ".cfg")
    measure.run([sys.executable, "scenes/gen.py", "bumpy", cfg, str(segs), str(rings)], cwd=ctx.root,
                what="scenes/gen.py bumpy")
    return cfg, 2 * segs * (rings - 1)


def generate(ctx, gen):
    """{name: {"scene": path, "expect_primitives": n, "what": text}} for
    ctx.embree_scenes."""
    out = {}
    for s in ctx.embree_scenes:
        if s == "three":
            scene = os.path.join(gen, "three.json")
            with_triangle_floor(ctx, "scenes/diffuse.cfg", scene)
            out[s] = {"scene": scene, "expect_primitives": 5,
                      "what": "scenes/diffuse.cfg with its plane as two triangles: 3 Lambert spheres, 2 point lights"}
        elif s == "spheres10k":
            n = SPHERES[ctx.quick]
            cfg = os.path.join(gen, "spheres10k.cfg")
            measure.run([sys.executable, "scenes/gen.py", "spheres", cfg, str(n)], cwd=ctx.root,
                        what="scenes/gen.py spheres")
            scene = os.path.join(gen, "spheres10k.json")
            with_triangle_floor(ctx, cfg, scene)
            out[s] = {"scene": scene, "expect_primitives": n + 2,
                      "what": "scenes/gen.py spheres %d with its plane as two triangles: %s Phong spheres on a "
                              "%dx%d grid, 1 point + 1 directional light" % (
                                  n, "{:,}".format(n), math.ceil(math.sqrt(n)), math.ceil(math.sqrt(n)))}
        else:
            segs, rings = BUMPY[ctx.quick]
            scene, tris = bumpy(ctx, gen, "bumpy1m", segs, rings)
            out[s] = {"scene": scene, "expect_primitives": tris + 2, "triangles": tris,
                      "what": "scenes/gen.py bumpy %d %d: a bumpy Lambert sphere of %s flat triangles, "
                              "2 point lights" % (segs, rings, "{:,}".format(tris))}
        out[s]["floor"] = "%g x %g" % (2 * FLOOR_HALF, 2 * FLOOR_HALF)
    return out


def embree_runs(out, mode, threads):
    return [r for r in out["runs"] if r["mode"] == mode and r["threads"] == threads]


def compare_one(ctx, name, scene, expect, threads, modes, rayd_extra=()):
    """One configuration, runs times: rayd, then Embree's modes. The runs'
    records and the best figures."""
    w, h = ctx.size
    h_path = harness(ctx)
    rr, er, pr = [], [], []
    for _ in range(ctx.runs):
        r, st = measure.rayd_render(ctx.rayd, scene, "/dev/null", w, h, threads,
                                    ["--samples", "1"] + MAX_OBJECTS + list(rayd_extra), cwd=ctx.root)
        if st["primitives"] != expect:
            raise measure.Failed("%s: rayd reports %d primitives, not %d" % (name, st["primitives"], expect))
        if st["secondary_rays"]:
            raise measure.Failed("%s: rayd traced %d secondary rays; Embree's harness traces none"
                                 % (name, st["secondary_rays"]))
        rr.append(dict(r.record(), stats=measure.stats_record(st), render_ms=st["time_ms"] - st["prepare_ms"]))
        r, sp = measure.rayd_render(ctx.rayd, scene, "/dev/null", w, h, threads,
                                    ["--samples", "1", "--packets", "all"] + MAX_OBJECTS + list(rayd_extra),
                                    cwd=ctx.root)
        if (sp["camera_rays"], sp["shadow_rays"]) != (st["camera_rays"], st["shadow_rays"]):
            raise measure.Failed("%s: rayd --packets all traced %d + %d rays, ray by ray %d + %d" % (
                name, sp["camera_rays"], sp["shadow_rays"], st["camera_rays"], st["shadow_rays"]))
        pr.append(dict(r.record(), stats=measure.stats_record(sp), render_ms=sp["time_ms"] - sp["prepare_ms"]))
        e, out = measure.embree_trace(h_path, scene, w, h, threads, modes, MAX_OBJECTS, cwd=ctx.root)
        if out["rayd_primitives"] != expect:
            raise measure.Failed("%s: embree_trace built %d primitives, not %d"
                                 % (name, out["rayd_primitives"], expect))
        er.append(dict(e.record(), out=out))
    last, eo = rr[-1]["stats"], er[-1]["out"]
    best = measure.best
    row = {
        "scene": name, "threads": threads, "width": w, "height": h, "rayd": rr, "rayd_packets": pr, "embree": er,
        "camera_rays": last["camera_rays"], "shadow_rays": last["shadow_rays"], "rays_rayd": measure.rays(last),
        "primitives": last["primitives"], "bvh_nodes": last["bvh_nodes"],
        "embree_version": eo["embree"], "quality": eo["quality"], "build_threads": eo["build_threads"],
        "native_ray16": eo["native_ray16"], "tile": eo["tile"],
        "best": {
            "rayd_render_ms": best(x["render_ms"] for x in rr),
            "rayd_packets_render_ms": best(x["render_ms"] for x in pr),
            "rayd_time_ms": best(x["stats"]["time_ms"] for x in rr),
            "rayd_bvh_build_ms": best(x["stats"]["bvh_build_ms"] for x in rr),
            "embree_build_ms": best(x["out"]["build_ms"] for x in er),
        },
        "load_ms": best(x["wall_ms"] - x["stats"]["time_ms"] for x in rr),
        "modes": {},
    }
    for m in modes:
        runs = [y for x in er for y in embree_runs(x["out"], m, threads)]
        ref = runs[-1]
        row["modes"][m] = {
            "camera_rays": ref["camera_rays"], "shadow_rays": ref["shadow_rays"], "rays": ref["rays"],
            "hits": ref["hits"], "occluded": ref["occluded"], "checksum": ref["checksum"],
            "best_seconds": best(y["seconds"] for y in runs),
            # Every run of the mode traced the same: the same answers each time.
            "stable": len({(y["rays"], y["hits"], y["occluded"], y["checksum"]) for y in runs}) == 1,
        }
        row["best"]["embree_%s_s" % m] = row["modes"][m]["best_seconds"]
    ms = list(row["modes"].values())
    row["same_rays"] = all(x["rays"] == row["rays_rayd"] for x in ms)
    row["modes_agree"] = len({(x["rays"], x["hits"], x["occluded"], x["checksum"]) for x in ms}) == 1 and all(
        x["stable"] for x in ms)
    if not row["modes_agree"]:
        raise measure.Failed("%s, %d thread(s): Embree's modes or runs traced different rays or found different "
                             "hits: %s" % (name, threads, json.dumps(row["modes"])))
    return row


def run(ctx):
    gen = ctx.path("gen-embree")
    os.makedirs(gen, exist_ok=True)
    harness(ctx)
    print("  generating the scenes ...", flush=True)
    scenes = generate(ctx, gen)
    rows = []
    for s in ctx.embree_scenes:
        g = scenes[s]
        for t in ctx.threads:
            print("  %s, %d thread(s), %d run(s) ..." % (s, t, ctx.runs), flush=True)
            rows.append(compare_one(ctx, s, g["scene"], g["expect_primitives"], t, ("single", "packet")))
    w, h = ctx.size
    return {"settings": {"size": [w, h], "threads": ctx.threads, "runs": ctx.runs, "scenes": ctx.embree_scenes},
            "scenes": {s: {k: v for k, v in g.items() if k != "scene"} for s, g in scenes.items()}, "rows": rows}
