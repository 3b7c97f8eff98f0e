"""Tables 2 and 3: large scenes generated at bench time (10,000 spheres; a
1,000,000-triangle torus knot) at 960x540, rayd against POV-Ray on files
that bench/cfg2pov.py makes from the same scenes; loading, BVH build and
tracing apart, and the BVH of the knot. First, the converter is checked:
POV-Ray on its conversion of scenes/diffuse.cfg and phong.cfg against POV-Ray
on the hand-written bench/NAME.pov, and rayd against POV-Ray on its files of
those and of blinn_phong.cfg and directional_light.cfg, compared with
`rayd compare`."""
import json
import os
import sys

from .. import measure

TITLE = "large generated scenes, rayd against POV-Ray on bench/cfg2pov.py's files"
TOOLS = ("povray",)

# scenes/gen.py arguments: full size, and --quick. 2 * 4000 * 125 = 1,000,000.
SPHERES = {False: 10000, True: 500}
KNOT = {False: (4000, 125), True: (100, 25)}
# A million triangles and the floor are one over rayd's default limit.
MAX_OBJECTS = ["--limit-objects", "2000000"]


def scene_files(ctx, gen):
    """The scenes as rayd files in gen/ (bench/rayd_bench/scene_set.py
    lists them too): {name: {"scene": path, "expect_primitives": n, "what":
    text}}."""
    out = {}
    py = sys.executable
    for s in ctx.large:
        if s == "spheres10k":
            n = SPHERES[ctx.quick]
            cfg = os.path.join(gen, "spheres10k.cfg")
            measure.run([py, "scenes/gen.py", "spheres", cfg, str(n)], cwd=ctx.root, what="scenes/gen.py spheres")
            scene = cfg
            out[s] = {"expect_primitives": n + 1, "spheres": n,
                      "what": "scenes/gen.py spheres %d: %s Phong spheres on a Lambert plane, "
                              "1 point + 1 directional light" % (n, "{:,}".format(n))}
        else:
            segs, sides = KNOT[ctx.quick]
            obj = os.path.join(gen, "knot1m.obj")
            measure.run([py, "scenes/gen.py", "knot", obj, str(segs), str(sides)], cwd=ctx.root,
                        what="scenes/gen.py knot")
            # scenes/mesh.cfg as it is, only pointing at the big knot: rayd
            # itself writes it as JSON, and only the mesh's file changes.
            r = measure.run([ctx.rayd, "convert", "scenes/mesh.cfg", "-", "--to", "json"], cwd=ctx.root,
                            what="rayd convert")
            doc = json.loads(r.stdout)
            meshes = [o for o in doc["objects"] if o["type"] == "mesh"]
            if len(meshes) != 1:
                raise measure.Failed("scenes/mesh.cfg has %d meshes, not one" % len(meshes))
            meshes[0]["file"] = "knot1m.obj"
            scene = os.path.join(gen, "knot1m.json")
            with open(scene, "w") as f:
                json.dump(doc, f, indent=1)
            tris = 2 * segs * sides
            out[s] = {"expect_primitives": tris + 1, "triangles": tris,
                      "what": "scenes/mesh.cfg with scenes/gen.py knot %d %d: %s triangles, Cook-Torrance gold "
                              "on a Lambert plane, 2 point lights" % (segs, sides, "{:,}".format(tris))}
        out[s]["scene"] = scene
    return out


def generate(ctx, gen):
    """The scenes as rayd files in gen/, and their POV-Ray files:
    {name: {"scene": path, "pov": path, "expect_primitives": n, "what": text}}."""
    w, h = ctx.large_size
    py = sys.executable
    out = scene_files(ctx, gen)
    for s in out:
        scene = out[s]["scene"]
        pov = os.path.join(gen, s + ".pov")
        measure.run([py, "bench/cfg2pov.py", scene, pov, "--width", str(w), "--height", str(h),
                     "--rayd", ctx.rayd] + MAX_OBJECTS, cwd=ctx.root, what="bench/cfg2pov.py on " + s)
        out[s]["pov"] = pov
    return out


def check_cfg2pov(ctx, gen, t):
    """The converter against the hand-written files, both through POV-Ray,
    and rayd against POV-Ray on its files of the other scenes it converts."""
    w, h = ctx.large_size
    py = sys.executable
    checks = []
    for s in ("diffuse", "phong", "blinn_phong", "directional_light"):
        pov = os.path.join(gen, s + ".pov")
        measure.run([py, "bench/cfg2pov.py", "scenes/%s.cfg" % s, pov, "--width", str(w), "--height", str(h),
                     "--rayd", ctx.rayd], cwd=ctx.root, what="bench/cfg2pov.py on scenes/%s.cfg" % s)
        hand, conv, rd = (ctx.path("check-%s-%s.png" % (s, k)) for k in ("hand", "cfg2pov", "rayd"))
        has_hand = os.path.isfile(os.path.join(ctx.root, "bench", s + ".pov"))
        if has_hand:
            measure.povray("bench/%s.pov" % s, hand, w, h, t, cwd=ctx.root)
        measure.povray(pov, conv, w, h, t, cwd=ctx.root)
        measure.rayd_render(ctx.rayd, "scenes/%s.cfg" % s, rd, w, h, t, cwd=ctx.root)
        checks.append({"scene": s, "size": [w, h],
                       "hand_vs_cfg2pov": measure.compare(ctx.rayd, hand, conv) if has_hand else None,
                       "rayd_vs_cfg2pov": measure.compare(ctx.rayd, rd, conv)})
    return checks


def run(ctx):
    w, h = ctx.large_size
    gen = ctx.path("gen")
    os.makedirs(gen, exist_ok=True)
    print("  generating the scenes and their POV-Ray files ...", flush=True)
    scenes = generate(ctx, gen)
    t1 = ctx.threads[0]
    print("  checking bench/cfg2pov.py ...", flush=True)
    checks = check_cfg2pov(ctx, gen, t1)
    rows = []
    best = measure.best
    for s in ctx.large:
        g = scenes[s]
        for t in ctx.threads:
            print("  %s, %d thread(s), %d run(s) ..." % (s, t, ctx.runs), flush=True)
            rr, pr = [], []
            out_r, out_p = ctx.path("%s-t%d-rayd.png" % (s, t)), ctx.path("%s-t%d-povray.png" % (s, t))
            for _ in range(ctx.runs):
                r, st = measure.rayd_render(ctx.rayd, g["scene"], out_r, w, h, t, MAX_OBJECTS, cwd=ctx.root)
                if st["primitives"] != g["expect_primitives"]:
                    raise measure.Failed("%s: rayd reports %d primitives, not %d"
                                         % (s, st["primitives"], g["expect_primitives"]))
                rr.append(dict(r.record(), stats=measure.stats_record(st),
                               load_ms=r.wall_ms - st["time_ms"], render_ms=st["time_ms"] - st["prepare_ms"]))
                p, pst = measure.povray(g["pov"], out_p, w, h, t, cwd=ctx.root)
                pr.append(dict(p.record(), **pst))
            last = rr[-1]["stats"]
            rows.append({
                "scene": s, "threads": t, "width": w, "height": h, "rayd": rr, "povray": pr,
                "best": {
                    "rayd_wall_ms": best(x["wall_ms"] for x in rr),
                    "rayd_load_ms": best(x["load_ms"] for x in rr),
                    "rayd_prepare_ms": best(x["stats"]["prepare_ms"] for x in rr),
                    "rayd_render_ms": best(x["render_ms"] for x in rr),
                    "rayd_bvh_build_ms": best(x["stats"]["bvh_build_ms"] for x in rr),
                    "rayd_peak_rss_kb": best((x["peak_rss_kb"] for x in rr), max),
                    "povray_wall_ms": best(x["wall_ms"] for x in pr),
                    "povray_parse_ms": best(x["parse_ms"] for x in pr),
                    "povray_bound_ms": best(x["bound_ms"] for x in pr),
                    "povray_trace_ms": best(x["trace_ms"] for x in pr),
                    "povray_peak_rss_kb": best((x["peak_rss_kb"] for x in pr), max),
                },
                "rays_rayd": measure.rays(last), "rays_povray": pr[-1]["rays"] + pr[-1]["shadow_tests"],
                "camera_rays": last["camera_rays"], "shadow_rays": last["shadow_rays"],
                "bvh_nodes": last["bvh_nodes"], "primitives": last["primitives"], "world_bytes": last["world_bytes"],
                "images": measure.compare(ctx.rayd, out_r, out_p) if t == t1 else None,
            })
    return {"settings": {"size": [w, h], "threads": ctx.threads, "runs": ctx.runs},
            "scenes": {s: {k: v for k, v in g.items() if k not in ("scene", "pov")} for s, g in scenes.items()},
            "povray": measure.povray_version(), "povray_overhead_ms": ctx.povray_overhead(),
            "cfg2pov_check": checks, "rows": rows}
