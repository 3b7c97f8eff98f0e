"""cfg2pov.py: a rayd scene written as a POV-Ray 3.7 scene, for the benchmark.

usage: cfg2pov.py SCENE OUT.pov [--width W --height H]
                  [--area-size N] [--area-adaptive A] [--rayd PATH] [--limit-NAME N ...]

SCENE is any scene rayd reads (.cfg or .json). It is read by rayd itself:
`rayd convert SCENE - --to json --expand` gives every key with its value and
each mesh as rayd loaded it (world coordinates, polygons fanned), so this
program has no scene or OBJ parser and no defaults of its own, and the
POV-Ray file is of the scene rayd renders. --rayd names the binary (default
build/rayd beside bench/); --limit-NAME N (for example --limit-objects 2000000
for a million triangles) goes to rayd convert.

W x H is the image size the .pov will be rendered at (POV-Ray's camera needs
the aspect ratio); it defaults to the scene's render width and height.
--area-size N gives every area light N x N points instead of the scene's
samples per side; --area-adaptive A adds POV-Ray's `adaptive A` to them
(default: none, every point is sampled). Render the result as the benchmark
does:

    povray +IOUT.pov +OOUT.png +FN +WW +HH -D -A +Q9 File_Gamma=1.0

It writes the same scene, number for number, with the conventions of the
hand-written bench/diffuse.pov and bench/phong.pov (see bench/README.md):

  - camera: POV-Ray's `right -x*W/H` makes its camera right-handed like
    rayd's (x right, y up), so every coordinate is copied as is; the vertical
    fov becomes the horizontal `angle 2*atan(W/H*tan(fov/2))`;
  - lights: point -> light_source at the same position and colour (no
    attenuation, hard shadows); directional -> a `parallel` light_source
    placed far up-light of the scene, pointing along the scene's direction;
    area (samples n) -> a light_source at the parallelogram's centre with
    `area_light edge1*(n-1)/n, edge2*(n-1)/n, n, n jitter area_illumination
    on`: POV-Ray spaces its points A/(n-1) apart from -A/2 to +A/2 and
    jitters each by half a spacing, so these are rayd's n x n jittered
    cells, and both split the colour evenly over the points (same
    brightness); see area_light() for what still differs;
  - materials (pigment = kd, `diffuse 1 brilliance 1`, i.e. kd*cos):
      diffuse        exact;
      phong          exact for grey ks: `phong ks phong_size shininess`;
      blinn_phong    exact for grey ks: `specular ks roughness 1/shininess`;
      cook_torrance  APPROXIMATED by a Phong highlight: amount mean(F0)/(4 pi m^2)
                     (the Beckmann peak at normal incidence), phong_size
                     (1/m^2 - 1)/2 (Beckmann ~ Blinn exponent 2/m^2 - 2, which
                     is about 4x a Phong exponent);
    a coloured ks is replaced by its mean (POV-Ray's phong/specular is a
    scalar); `ambient` is written as ambient/kd per channel, because POV-Ray
    multiplies the finish's ambient by the pigment (ambient_light 1);
  - objects: sphere, plane (two-sided in both), triangle (smooth_triangle
    when it has n0 n1 n2), mesh: rayd's loaded mesh becomes a mesh2 with
    normal_vectors; faces whose three corners all have a normal are smooth
    (as in rayd), the others go into a flat `mesh`;
  - output gamma: rayd writes clamp(c)^(1/gamma); the .pov has assumed_gamma 1
    and the command line must say File_Gamma=<gamma> (1 by default).
rayd validates the scene before this sees it.
Not supported (an error): spot lights, area lights of 1 x 1 (POV-Ray does
not jitter those), mirrors, glass, textures, pseudo_normal_color. samples > 1
gets a warning: POV-Ray's -A renders one ray per pixel centre, +A would be
its own antialiasing.
"""
import json
import math
import os
import subprocess
import sys


class Bad(Exception):
    pass


def f(x):
    """A float as POV-Ray text that reads back as the same double."""
    x = float(x)
    if x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return repr(x)


def vec(v):
    return "<%s, %s, %s>" % (f(v[0]), f(v[1]), f(v[2]))


# ---------------------------------------------------------------- reader

def read_scene(rayd, path, limits):
    """The scene as rayd renders it: `rayd convert --expand` JSON."""
    cmd = [rayd, "convert", path, "-", "--to", "json", "--expand"] + limits
    try:
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, check=False)
    except OSError as e:
        raise Bad("cannot run %s: %s" % (rayd, e))
    if p.returncode != 0:
        raise Bad("rayd convert failed (exit %d): %s" % (p.returncode, p.stderr.decode("utf-8", "replace").strip()))
    return json.loads(p.stdout)


# ---------------------------------------------------------------- writer

def material(name, m, ident, out, warn):
    typ = m["type"]
    if typ not in ("diffuse", "phong", "blinn_phong", "cook_torrance"):
        raise Bad("material %s: type %s is not supported by cfg2pov" % (name, typ))
    kd = m["kd"]
    ka = m["ambient"]
    ratio = []
    for c in range(3):
        if kd[c] != 0:
            ratio.append(ka[c] / kd[c])
        else:
            if ka[c] != 0:
                warn("material %s: kd is 0 in channel %d, its ambient %g is lost" % (name, c, ka[c]))
            ratio.append(0.0)
    fin = "ambient rgb %s diffuse 1 brilliance 1" % vec(ratio)
    note = "rayd %s" % typ

    def grey(ks):
        if not (ks[0] == ks[1] == ks[2]):
            warn("material %s: coloured ks %s written as its mean" % (name, " ".join(map(f, ks))))
        return sum(ks) / 3.0

    if typ == "diffuse":
        fin += " specular 0 phong 0"
    elif typ == "phong":
        fin += " specular 0 phong %s phong_size %s metallic 0" % (f(grey(m["ks"])), f(m["shininess"]))
    elif typ == "blinn_phong":
        fin += " phong 0 specular %s roughness %s metallic 0" % (f(grey(m["ks"])), f(1.0 / m["shininess"]))
    elif typ == "cook_torrance":
        ks = m["ks"]
        r = m["roughness"]
        amount = (sum(ks) / 3.0) / (4 * math.pi * r * r)
        size = max(1.0, (1.0 / (r * r) - 1.0) / 2.0)
        fin += " specular 0 phong %s phong_size %s metallic 0" % (f(amount), f(size))
        note = "rayd cook_torrance (F0 %s, roughness %s) APPROXIMATED as Phong" % (" ".join(map(f, ks)), f(r))
    out.write("// [material %s]: %s\n" % (name, note))
    out.write("#declare %s = texture {\n  pigment { rgb %s }\n  finish { %s reflection 0 }\n}\n"
              % (ident, vec(kd), fin))


def write_mesh(out, o, tex):
    mesh = o["loaded"]
    pos, nrm = mesh["positions"], mesh["normals"]
    smooth, flat = [], []
    for t in mesh["faces"]:
        if t[3] >= 0 and t[4] >= 0 and t[5] >= 0:
            smooth.append(t)
        else:
            flat.append(t[:3])
    out.write("// [mesh %s]: %s, %d vertices, %d normals, %d smooth + %d flat triangles\n"
              % (o.get("name", ""), o["file"], len(pos), len(nrm), len(smooth), len(flat)))
    if smooth:
        same = len(nrm) == len(pos) and all(t[0] == t[3] and t[1] == t[4] and t[2] == t[5] for t in smooth)
        w = out.write
        w("mesh2 {\n  vertex_vectors { %d" % len(pos))
        w("".join(",\n<%s,%s,%s>" % (f(p[0]), f(p[1]), f(p[2])) for p in pos))
        w("\n  }\n  normal_vectors { %d" % len(nrm))
        w("".join(",\n<%s,%s,%s>" % (f(n[0]), f(n[1]), f(n[2])) for n in nrm))
        w("\n  }\n  face_indices { %d" % len(smooth))
        w("".join(",\n<%d,%d,%d>" % tuple(t[:3]) for t in smooth))
        w("\n  }\n")
        if not same:
            w("  normal_indices { %d" % len(smooth))
            w("".join(",\n<%d,%d,%d>" % tuple(t[3:6]) for t in smooth))
            w("\n  }\n")
        w("  texture { %s }\n}\n" % tex)
    if flat:
        out.write("mesh {\n")
        out.write("".join("  triangle { %s, %s, %s }\n" % (vec(pos[a]), vec(pos[b]), vec(pos[c]))
                          for a, b, c in flat))
        out.write("  texture { %s }\n}\n" % tex)


def area_light(light, area):
    """A rayd area light as a POV-Ray jittered area_light with the same cells.

    rayd: `samples` = n puts one jittered point in each of n x n equal cells
    of the parallelogram corner + a*edge1 + b*edge2 (a, b in [0, 1]), each
    carrying color/n^2. POV-Ray 3.7: `area_light A1, A2, n1, n2` places its
    n1 x n2 lights at (i/(n1-1) - 1/2)*A1 + (j/(n2-1) - 1/2)*A2 about the
    light_source's location, and `jitter` moves each by up to half a spacing
    (A/(n-1)) either way; each carries color/(n1*n2) (the average over the
    grid), so its total is `color` too. With A = edge*(n-1)/n and the
    location at the parallelogram's centre, POV-Ray's spacing is edge/n and
    its jitter cells are exactly rayd's n x n cells. `area_illumination on`
    makes POV-Ray shade (diffuse, highlight) from every point as rayd does;
    without it POV-Ray shades from the centre only. Two differences remain:
    POV-Ray averages its shadow samples by recursive corner quartering (a
    trapezoid rule: edge points weigh 1/2, corners 1/4), so its light is a
    little centre-heavy and its penumbrae a little narrower; and it traces
    the visibility with other jitter than the shading and multiplies the
    two averages, which darkens surfaces where the light sets below their
    horizon. Both fade as n grows. area = (n, adaptive):
    n overrides the scene's samples per side (POV-Ray's adaptive mode wants
    2^k + 1); adaptive None writes no `adaptive` (every point sampled).
    """
    corner, e1, e2, col = light["corner"], light["edge1"], light["edge2"], light["color"]
    name = light.get("name")
    n = area[0] if area and area[0] else int(light["samples"])
    adaptive = area[1] if area else None
    centre = [corner[i] + 0.5 * (e1[i] + e2[i]) for i in range(3)]
    if n < 2:
        # POV-Ray puts a 1 x 1 area light at its centre, unjittered; rayd
        # jitters its one point over the whole light. 2 x 2 is the nearest.
        raise Bad("area light %s: samples %d: POV-Ray needs at least 2 per side (use --area-size)"
                  % (name or "", n))
    k = (n - 1) / n
    a1 = [x * k for x in e1]
    a2 = [x * k for x in e2]
    text = ("light_source { %s color rgb %s\n  area_light %s, %s, %d, %d jitter%s\n  area_illumination on\n}"
            % (vec(centre), vec(col), vec(a1), vec(a2), n, n,
               "" if adaptive is None else " adaptive %d" % adaptive))
    return ("%s  // %s, rayd area light: corner %s edge1 %s edge2 %s, %d x %d cells\n"
            % (text, name or "", vec(corner), vec(e1), vec(e2), n, n))


def convert(scene, label, dst, width, height, area=None):
    """Writes the expanded scene (read_scene) as POV-Ray text to dst; label
    names the scene in the file's first line."""
    warnings = []

    def warn(msg):
        warnings.append(msg)
        print("cfg2pov: warning: %s" % msg, file=sys.stderr)

    render, camera = scene["render"], scene["camera"]
    W = width or int(render["width"])
    H = height or int(render["height"])
    if render["samples"] != 1:
        warn("samples > 1: rendered with -A this is one ray per pixel centre")

    idents = {}
    for name in scene["materials"]:
        idents[name] = "M_%d" % len(idents)

    tmp = dst + ".tmp"
    with open(tmp, "w") as out:
        out.write("// %s: %s written for POV-Ray 3.7 by bench/cfg2pov.py.\n" % (os.path.basename(dst), label))
        out.write("// Render at %dx%d with -A File_Gamma=%s (see the docstring of bench/cfg2pov.py).\n"
                  % (W, H, f(render["gamma"])))
        for msg in warnings:
            out.write("// warning: %s\n" % msg)
        out.write("#version 3.7;\n\nglobal_settings {\n  assumed_gamma 1.0\n  ambient_light rgb 1\n"
                  "  max_trace_level %d\n}\n\n" % max(1, int(render["max_depth"])))
        out.write("camera {\n  perspective\n  location %s\n  look_at  %s\n  sky      %s\n  up       y\n"
                  "  right    -x*%d/%d\n  angle    2*degrees(atan(%d/%d*tan(radians(%s/2))))\n}\n\n"
                  % (vec(camera["eye"]), vec(camera["target"]), vec(camera["up"]), W, H, W, H, f(camera["fov"])))
        out.write("background { rgb %s }\n\n" % vec(render["background"]))

        # A directional light needs a far position: well outside the scene.
        ext = [abs(x) for x in camera["eye"] + camera["target"]]
        for o in scene["objects"]:
            if o["type"] == "sphere":
                ext += [abs(x) + o["radius"] for x in o["center"]]
        for light in scene["lights"]:
            if light["type"] == "point":
                ext += [abs(x) for x in light["position"]]
        far = 1e4 * (max(ext) + 1.0)

        for i, light in enumerate(scene["lights"]):
            typ, col, name = light["type"], light["color"], light.get("name", "")
            if typ == "point":
                out.write("light_source { %s color rgb %s }  // %s\n" % (vec(light["position"]), vec(col), name))
            elif typ == "directional":
                d = light["direction"]
                n = math.sqrt(sum(x * x for x in d))
                at = [-far * x / n for x in d]
                out.write("light_source { %s color rgb %s parallel point_at <0, 0, 0> }  // %s, directional %s\n"
                          % (vec(at), vec(col), name, vec(d)))
            elif typ == "area":
                try:
                    out.write(area_light(light, area))
                except Bad as e:
                    raise Bad("lights[%d]: %s" % (i, e))
            else:
                raise Bad("lights[%d]: %s lights are not supported by cfg2pov" % (i, typ))
        out.write("\n")

        for name, m in scene["materials"].items():
            material(name, m, idents[name], out, warn)
        out.write("\n")

        for i, o in enumerate(scene["objects"]):
            kind = o["type"]
            tex = idents[o["material"]]
            if kind == "sphere":
                out.write("sphere { %s, %s texture { %s } }\n" % (vec(o["center"]), f(o["radius"]), tex))
            elif kind == "plane":
                nv = o["normal"]
                ln = math.sqrt(sum(x * x for x in nv))
                nv = [x / ln for x in nv]
                out.write("plane { %s, %s texture { %s } }\n"
                          % (vec(nv), f(sum(a * b for a, b in zip(nv, o["point"]))), tex))
            elif kind == "triangle":
                v = [o["v%d" % k] for k in range(3)]
                if "n0" in o:
                    n = [o["n%d" % k] for k in range(3)]
                    out.write("smooth_triangle { %s, %s, %s, %s, %s, %s texture { %s } }\n"
                              % (vec(v[0]), vec(n[0]), vec(v[1]), vec(n[1]), vec(v[2]), vec(n[2]), tex))
                else:
                    out.write("triangle { %s, %s, %s texture { %s } }\n" % (vec(v[0]), vec(v[1]), vec(v[2]), tex))
            elif kind == "mesh":
                write_mesh(out, o, tex)
            else:
                raise Bad("objects[%d]: %s objects are not supported by cfg2pov" % (i, kind))
    os.replace(tmp, dst)


def default_rayd():
    return os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "build", "rayd")


def main(argv):
    args = argv[1:]
    width = height = None
    area_n = area_a = None
    rayd = default_rayd()
    limits = []
    pos = []
    i = 0
    while i < len(args):
        a = args[i]
        if a in ("--width", "--height") and i + 1 < len(args):
            try:
                v = int(args[i + 1])
            except ValueError:
                v = 0
            if v < 1:
                sys.exit("cfg2pov: %s must be a positive integer" % a)
            if a == "--width":
                width = v
            else:
                height = v
            i += 2
        elif a in ("--area-size", "--area-adaptive") and i + 1 < len(args):
            try:
                v = int(args[i + 1])
            except ValueError:
                v = -1
            if v < (2 if a == "--area-size" else 0):
                sys.exit("cfg2pov: %s: bad value '%s'" % (a, args[i + 1]))
            if a == "--area-size":
                area_n = v
            else:
                area_a = v
            i += 2
        elif a == "--rayd" and i + 1 < len(args):
            rayd = args[i + 1]
            i += 2
        elif a.startswith("--limit-") and i + 1 < len(args):
            limits += [a, args[i + 1]]
            i += 2
        elif a in ("-h", "--help"):
            print(__doc__)
            return 0
        elif a.startswith("-"):
            print("cfg2pov: unknown option '%s' (try --help)" % a, file=sys.stderr)
            return 2
        else:
            pos.append(a)
            i += 1
    if len(pos) != 2:
        print("usage: cfg2pov.py SCENE OUT.pov [--width W --height H] [--area-size N] [--area-adaptive A] "
              "[--rayd PATH] [--limit-NAME N ...]", file=sys.stderr)
        return 2
    try:
        convert(read_scene(rayd, pos[0], limits), pos[0], pos[1], width, height, (area_n, area_a))
    except (Bad, OSError, ValueError) as e:
        try:
            os.unlink(pos[1] + ".tmp")
        except OSError:
            pass
        print("cfg2pov: %s" % e, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
