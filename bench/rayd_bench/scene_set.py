"""Every scene `make bench` renders, as scene files: the bundled scenes its
sections name, and the scenes the large, embree and primitives sections
generate, made by those sections' own code (scenes/gen.py, `rayd convert`,
the two-triangle floor). bench/same_bytes.py and
tests/integration/same_bytes_test.py render them all.

    generate(rayd, gen, quick) -> [(name, path)]
    every_scene(rayd, gen, quick) -> [(name, path)]
    bench_renders(scenes) -> [(name, path, flags)]

writes the generated ones into the folder gen (one folder per section, as
the sections do: gen/large, gen/embree, gen/primitives) and lists them, name
being "large/knot1m.json" and the like. quick=True makes them at the sizes
of `make bench-quick` (500 spheres, a 5,000-triangle knot, a 2,000-triangle
bumpy sphere, bumpy spheres of 100 to 10,000 triangles); quick=False at the
sizes of `make bench` (10,000 spheres, the 1,000,000-triangle knot and bumpy
sphere, bumpy spheres of 100 to 1,000,000 triangles). Render them with
LIMITS: the million-triangle ones are over rayd's default --limit-objects.
every_scene adds every scene file in scenes/ (*.cfg, *.json), its
assignments/ and extreme/ to them, named by their path under scenes/
("extreme/flat_bvh.cfg"), the generated ones under "bench/".
bench_renders gives the renders of `make bench` itself (its sizes, samples,
seeds and --packets) of those scenes, for the sections that render through
`rayd render` with a fixed sample count.
"""
import glob
import os
import types

from . import runner
from .sections import embree, equal, large, primitives

ROOT = runner.ROOT

# scenes/NAME.cfg the sections render: scenes (diffuse, phong), large's
# converter check (blinn_phong, directional_light), converge, equal,
# mixed, store and overload (area_light, phong), http and base.
BUNDLED = ("area_light", "blinn_phong", "diffuse", "directional_light", "phong")

# The flags the large scenes are rendered with (large.py and embree.py).
LIMITS = tuple(large.MAX_OBJECTS)


def generate(rayd, gen, quick=False):
    """The generated scenes in gen (see the module's text): [(name, path)]."""
    gen = os.path.abspath(gen)
    ctx = types.SimpleNamespace(rayd=os.path.abspath(rayd), root=ROOT, quick=quick,
                                large=["spheres10k", "knot1m"], embree_scenes=list(runner.EMBREE_SCENES))
    out = []
    folder = os.path.join(gen, "large")
    os.makedirs(folder, exist_ok=True)
    for s, g in large.scene_files(ctx, folder).items():
        out.append(("large/" + os.path.basename(g["scene"]), g["scene"]))
    folder = os.path.join(gen, "embree")
    os.makedirs(folder, exist_ok=True)
    grids = set()
    for s, g in embree.generate(ctx, folder).items():
        out.append(("embree/" + os.path.basename(g["scene"]), g["scene"]))
    grids.add(embree.BUMPY[quick])
    folder = os.path.join(gen, "primitives")
    os.makedirs(folder, exist_ok=True)
    for n in sorted(primitives.GRIDS):
        if quick and n not in primitives.QUICK:
            continue
        # At full size the million-triangle count is embree's bumpy1m, the
        # same file: rendered once.
        if primitives.GRIDS[n] in grids:
            continue
        scene, _ = embree.bumpy(ctx, folder, "bumpy%d" % n, *primitives.GRIDS[n])
        out.append(("primitives/" + os.path.basename(scene), scene))
    return out


def bundled():
    """[(name, path)] of the bundled scenes the sections render."""
    return [("%s.cfg" % s, os.path.join(ROOT, "scenes", "%s.cfg" % s)) for s in BUNDLED]


def every_scene(rayd, gen, quick=False):
    """Every scene file in scenes/, scenes/assignments/ and scenes/extreme/,
    then the generated ones of generate() under "bench/": [(name, path)]."""
    scenes = os.path.join(ROOT, "scenes")
    out = []
    for pattern in ("*.cfg", "*.json", "assignments/*.cfg", "assignments/*.json", "extreme/*.cfg",
                    "extreme/*.json"):
        for path in sorted(glob.glob(os.path.join(scenes, pattern))):
            out.append((os.path.relpath(path, scenes), path))
    return out + [("bench/" + name, path) for name, path in generate(rayd, gen, quick)]


# runner.Context's sizes without --quick: ctx.size, ctx.large_size, ctx.eq_size.
SIZE, LARGE_SIZE, EQ_SIZE = (1920, 1080), (960, 540), (320, 240)
EQ_REF_SAMPLES = 512


def bench_renders(scenes):
    """The renders `make bench` makes of the scenes of every_scene() (given
    as its [(name, path)]), through `rayd render` with a fixed sample count
    (time budgets are left out: they stop by the clock): [(name, path,
    flags)], name the scene's and the settings."""
    path = dict(scenes)
    out = []

    def add(name, flags):
        if name in path:
            label = " ".join(str(f) for f in flags if f not in LIMITS)
            out.append(("%s %s" % (name, label), path[name], [str(f) for f in flags]))

    size = lambda wh: ["--width", wh[0], "--height", wh[1]]  # noqa: E731
    for s in ("diffuse", "phong"):  # scenes, base
        add(s + ".cfg", size(SIZE))
    for s in ("diffuse", "phong", "blinn_phong", "directional_light"):  # large's converter check
        add(s + ".cfg", size(LARGE_SIZE))
    for s in ("large/spheres10k.cfg", "large/knot1m.json"):
        add("bench/" + s, size(LARGE_SIZE) + list(LIMITS))
    for s in ("embree/three.json", "embree/spheres10k.json", "embree/bumpy1m.cfg"):
        add("bench/" + s, size(SIZE) + ["--samples", 1] + list(LIMITS))
        add("bench/" + s, size(SIZE) + ["--samples", 1, "--packets", "all"] + list(LIMITS))
    for n in sorted(primitives.GRIDS):
        add("bench/primitives/bumpy%d.cfg" % n, size(SIZE) + ["--samples", 1] + list(LIMITS))
    for s in equal.SCENES:
        add(s + ".cfg", size(EQ_SIZE) + ["--samples", equal.FIXED])
        add(s + ".cfg", size(EQ_SIZE) + ["--samples", EQ_REF_SAMPLES, "--seed", equal.REF_SEED])
    return out
