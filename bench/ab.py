#!/usr/bin/python3
"""Is one rayd build faster than another? Both render the embree section's
scenes (three, spheres10k, bumpy1m: bench/rayd_bench/sections/embree.py)
and scenes/diffuse.cfg and phong.cfg at 1920x1080, one sample, taking
turns RUNS times, so that a noisy machine weighs on both alike; the table
gives each one's least and median render time (the statistics' time_ms
less prepare_ms: loading and the BVH build apart), its Mrays/s at the least,
NEW's least over OLD's, and the same ratio of the least CPU time of the
whole process (user + system, loading included), which a busy machine
disturbs less than wall time. Every render of the two must trace the same rays
(camera + shadow + secondary), or the run stops.

    python3 bench/ab.py OLD NEW [--runs 5] [--threads 1] [--only three,bumpy1m] [--packets]

A one-off measurement for a change's note, not a test and not a section of
`make bench`. Run from the checkout's root; scenes are generated into
build/ab/ once."""
import argparse
import os
import statistics
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench"))
from rayd_bench import measure  # noqa: E402
from rayd_bench.sections import embree  # noqa: E402

GENERATED = ("three", "spheres10k", "bumpy1m")
BUNDLED = {"diffuse": "scenes/diffuse.cfg", "phong": "scenes/phong.cfg"}


class Ctx:
    def __init__(self, rayd, scenes):
        self.rayd, self.root, self.embree_scenes, self.quick = rayd, ROOT, scenes, False


def scenes(first, only):
    gen = os.path.join(ROOT, "build", "ab")
    os.makedirs(gen, exist_ok=True)
    wanted = [s for s in GENERATED if s in only]
    out = {k: v["scene"] for k, v in embree.generate(Ctx(first, wanted), gen).items()} if wanted else {}
    out.update({k: os.path.join(ROOT, v) for k, v in BUNDLED.items() if k in only})
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--only", default=",".join(GENERATED + tuple(BUNDLED)))
    ap.add_argument("--packets", action="store_true", help="both render with --packets all")
    a = ap.parse_args()
    only = a.only.split(",")
    extra = ["--samples", "1"] + embree.MAX_OBJECTS + (["--packets", "all"] if a.packets else [])
    print("load average %.2f" % os.getloadavg()[0])
    print("| scene | old least / median ms | new least / median ms | old / new Mrays/s | new / old time | new / old CPU |")
    print("|---|---|---|---|---|---|")
    for name, scene in scenes(a.old, only).items():
        ms = {"old": [], "new": []}
        cpu = {"old": [], "new": []}
        rays = {}
        for _ in range(a.runs):
            for side in ("old", "new"):
                run, st = measure.rayd_render(getattr(a, side), scene, "/dev/null", 1920, 1080, a.threads, extra,
                                            cwd=ROOT)
                ms[side].append(st["time_ms"] - st["prepare_ms"])
                cpu[side].append(run.user_s + run.sys_s)
                n = measure.rays(st)
                if rays.setdefault(side, n) != n or rays.get("old", n) != n:
                    raise SystemExit("%s: the builds traced different rays (%s, %d)" % (name, rays, n))
        lo = {k: min(v) for k, v in ms.items()}
        print("| %s | %.0f / %.0f | %.0f / %.0f | %.2f / %.2f | %.3f | %.3f |" % (
            name, lo["old"], statistics.median(ms["old"]), lo["new"], statistics.median(ms["new"]),
            rays["old"] / lo["old"] / 1e3, rays["new"] / lo["new"] / 1e3, lo["new"] / lo["old"],
            min(cpu["new"]) / min(cpu["old"])))
        sys.stdout.flush()
    print("load average %.2f" % os.getloadavg()[0])


if __name__ == "__main__":
    main()
