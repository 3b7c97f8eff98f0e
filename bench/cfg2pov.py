#!/usr/bin/python3
"""cfg2pov.py: a rayd cfg scene written as a POV-Ray 3.7 scene, for bench/run.sh.

usage: cfg2pov.py SCENE.cfg OUT.pov [--width W --height H]
                  [--area-size N] [--area-adaptive A]

W x H is the image size the .pov will be rendered at (POV-Ray's camera needs
the aspect ratio); it defaults to the cfg's [render] width and height.
--area-size N gives every area light N x N points instead of the cfg's
samples per side; --area-adaptive A adds POV-Ray's `adaptive A` to them
(default: none, every point is sampled). Render the result as bench/run.sh
does:

    povray +IOUT.pov +OOUT.png +FN +WW +HH -D -A +Q9 File_Gamma=1.0

It writes the same scene, number for number, with the conventions of the
hand-written bench/diffuse.pov and bench/phong.pov (see bench/README.md):

  - camera: POV-Ray's `right -x*W/H` makes its camera right-handed like the
    cfg (x right, y up), so every coordinate is copied as is; the cfg's
    vertical fov becomes the horizontal `angle 2*atan(W/H*tan(fov/2))`;
  - lights: point -> light_source at the same position and colour (no
    attenuation, hard shadows); directional -> a `parallel` light_source
    placed far up-light of the scene, pointing along the cfg's direction;
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
    when it has n0 n1 n2), mesh: the OBJ file (relative to the cfg's folder)
    becomes a mesh2 with normal_vectors, faces fanned as rayd fans them;
    faces whose three corners all have a normal are smooth (as in rayd),
    the others go into a flat `mesh`; translate/scale/rotate are applied here
    exactly as rayd applies them (scale, rotate x then y then z, translate;
    normals by the inverse transpose);
  - output gamma: rayd writes clamp(c)^(1/gamma); the .pov has assumed_gamma 1
    and the command line must say File_Gamma=<gamma> (1 by default).
The scene is expected to be one rayd accepts (rayd validates it; this does not).
Not supported (an error): spot lights, area lights of 1 x 1 (POV-Ray does
not jitter those), mirrors, glass, textures, pseudo_normal_color, JSON
scenes. samples > 1 gets a warning: POV-Ray's -A renders one ray per pixel
centre, +A would be its own antialiasing.
"""
import math
import os
import re
import sys


class Bad(Exception):
    pass


def num(s):
    try:
        x = float(s)
    except ValueError:
        raise Bad("expected a number, got '%s'" % s)
    if not math.isfinite(x):
        raise Bad("expected a finite number, got '%s'" % s)
    return x


def f(x):
    """A float as POV-Ray text that reads back as the same double."""
    x = float(x)
    if x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return repr(x)


def vec(v):
    return "<%s, %s, %s>" % (f(v[0]), f(v[1]), f(v[2]))


# ---------------------------------------------------------------- cfg reader

def strip_comment(line):
    out = []
    q = False
    for ch in line:
        if ch == '"':
            q = not q
        elif not q and ch in "#;":
            break
        out.append(ch)
    return "".join(out).strip()


def read_cfg(path):
    """[(kind, name, {key: (value text, line)}, line)] in file order."""
    with open(path, "rb") as fh:
        text = fh.read().decode("utf-8")
    if text.startswith("\ufeff"):
        text = text[1:]
    sections = []
    cur = None
    for ln, raw in enumerate(text.splitlines(), 1):
        line = strip_comment(raw)
        if not line:
            continue
        where = "%s:%d" % (path, ln)
        if line.startswith("["):
            m = re.fullmatch(r"\[\s*([A-Za-z_]\w*)(?:\s+([^\]]+?))?\s*\]", line)
            if not m:
                raise Bad("%s: bad section header '%s'" % (where, line))
            cur = (m.group(1), m.group(2), {}, ln)
            sections.append(cur)
            continue
        if cur is None or "=" not in line:
            raise Bad("%s: expected [section] or key = value" % where)
        k, v = line.split("=", 1)
        k, v = k.strip(), v.strip()
        if len(v) >= 2 and v[0] == '"' and v[-1] == '"':
            v = v[1:-1]
        cur[2][k] = (v, where)
    return sections


def get(keys, k, default=None, n=None):
    if k not in keys:
        if default is None:
            raise Bad("missing key '%s'" % k)
        return default
    v, where = keys[k]
    if n is None:
        return v
    try:
        xs = [num(t) for t in v.split()]
    except Bad as e:
        raise Bad("%s: %s: %s" % (where, k, e))
    if len(xs) != n:
        raise Bad("%s: %s: expected %d numbers, got %d" % (where, k, n, len(xs)))
    return xs if n > 1 else xs[0]


# ---------------------------------------------------------------- OBJ reader

def read_obj(path):
    """positions, normals, smooth faces [(v0,v1,v2,n0,n1,n2)], flat faces [(v0,v1,v2)], 0-based."""
    pos, nrm, smooth, flat = [], [], [], []
    with open(path, encoding="utf-8", newline="\n") as fh:
        for ln, line in enumerate(fh, 1):
            h = line.find("#")
            if h >= 0:
                line = line[:h]
            t = line.split()
            if not t:
                continue
            kw = t[0]
            try:
                if kw == "v":
                    pos.append((num(t[1]), num(t[2]), num(t[3])))
                elif kw == "vn":
                    nrm.append((num(t[1]), num(t[2]), num(t[3])))
                elif kw == "f":
                    cv, cn = [], []
                    for c in t[1:]:
                        parts = c.split("/")
                        i = int(parts[0])
                        cv.append(i - 1 if i > 0 else len(pos) + i)
                        if len(parts) > 2 and parts[2]:
                            j = int(parts[2])
                            cn.append(j - 1 if j > 0 else len(nrm) + j)
                        else:
                            cn.append(None)
                    if len(cv) < 3:
                        raise Bad("a face needs at least 3 corners")
                    for i in range(1, len(cv) - 1):
                        a, b, c = 0, i, i + 1
                        if cn[a] is not None and cn[b] is not None and cn[c] is not None:
                            smooth.append((cv[a], cv[b], cv[c], cn[a], cn[b], cn[c]))
                        else:
                            flat.append((cv[a], cv[b], cv[c]))
            except (Bad, ValueError, IndexError) as e:
                raise Bad("%s:%d: %s" % (path, ln, e))
    for t in smooth:
        if max(t[:3]) >= len(pos) or min(t[:3]) < 0 or max(t[3:]) >= len(nrm) or min(t[3:]) < 0:
            raise Bad("%s: a face index is out of range" % path)
    for t in flat:
        if max(t) >= len(pos) or min(t) < 0:
            raise Bad("%s: a face index is out of range" % path)
    return pos, nrm, smooth, flat


def transform(pos, nrm, t, s, r):
    """rayd's rd_mesh_transform: scale, rotate about x, y, z (degrees), translate."""
    if s == [1, 1, 1] and r == [0, 0, 0] and t == [0, 0, 0]:
        return pos, nrm
    if 0 in s:
        raise Bad("scale: every component must be non-zero")
    k = math.pi / 180.0
    cx, sx, cy, sy = math.cos(r[0] * k), math.sin(r[0] * k), math.cos(r[1] * k), math.sin(r[1] * k)
    cz, sz = math.cos(r[2] * k), math.sin(r[2] * k)
    rot = r != [0, 0, 0]

    def rotate(p):
        a = (p[0], cx * p[1] - sx * p[2], sx * p[1] + cx * p[2])
        b = (cy * a[0] + sy * a[2], a[1], -sy * a[0] + cy * a[2])
        return (cz * b[0] - sz * b[1], sz * b[0] + cz * b[1], b[2])

    out_p = []
    for p in pos:
        p = (p[0] * s[0], p[1] * s[1], p[2] * s[2])
        if rot:
            p = rotate(p)
        out_p.append((p[0] + t[0], p[1] + t[1], p[2] + t[2]))
    out_n = []
    for n in nrm:
        n = (n[0] / s[0], n[1] / s[1], n[2] / s[2])
        out_n.append(rotate(n) if rot else n)
    return out_p, out_n


# ---------------------------------------------------------------- writer

def material(name, keys, ident, out, warn):
    typ = get(keys, "type")
    kd = get(keys, "kd", [0.8, 0.8, 0.8], 3)
    ka = get(keys, "ambient", [0.0, 0.0, 0.0], 3)
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
        ks = get(keys, "ks", [0.0, 0.0, 0.0], 3)
        n = get(keys, "shininess", 1.0, 1)
        fin += " specular 0 phong %s phong_size %s metallic 0" % (f(grey(ks)), f(n))
    elif typ == "blinn_phong":
        ks = get(keys, "ks", [0.0, 0.0, 0.0], 3)
        n = get(keys, "shininess", 1.0, 1)
        fin += " phong 0 specular %s roughness %s metallic 0" % (f(grey(ks)), f(1.0 / n))
    elif typ == "cook_torrance":
        ks = get(keys, "ks", [0.04, 0.04, 0.04], 3)
        m = get(keys, "roughness", 0.3, 1)
        amount = (sum(ks) / 3.0) / (4 * math.pi * m * m)
        size = max(1.0, (1.0 / (m * m) - 1.0) / 2.0)
        fin += " specular 0 phong %s phong_size %s metallic 0" % (f(amount), f(size))
        note = "rayd cook_torrance (F0 %s, roughness %s) APPROXIMATED as Phong" % (" ".join(map(f, ks)), f(m))
    else:
        raise Bad("material %s: type %s is not supported by cfg2pov" % (name, typ))
    out.write("// [material %s]: %s\n" % (name, note))
    out.write("#declare %s = texture {\n  pigment { rgb %s }\n  finish { %s reflection 0 }\n}\n"
              % (ident, vec(kd), fin))


def write_mesh(out, keys, base, tex, name):
    fn = get(keys, "file")
    path = os.path.join(base, fn)
    pos, nrm, smooth, flat = read_obj(path)
    tr = get(keys, "translate", [0.0, 0.0, 0.0], 3)
    sc = keys.get("scale")
    if sc is None:
        sc = [1.0, 1.0, 1.0]
    else:
        xs = [num(x) for x in sc[0].split()]
        sc = xs * 3 if len(xs) == 1 else xs
        if len(sc) != 3:
            raise Bad("%s: scale: expected 1 or 3 numbers" % keys["scale"][1])
    rot = get(keys, "rotate", [0.0, 0.0, 0.0], 3)
    pos, nrm = transform(pos, nrm, tr, sc, rot)
    out.write("// [mesh %s]: %s, %d vertices, %d normals, %d smooth + %d flat triangles\n"
              % (name or "", fn, len(pos), len(nrm), len(smooth), len(flat)))
    if smooth:
        same = len(nrm) == len(pos) and all(t[0] == t[3] and t[1] == t[4] and t[2] == t[5] for t in smooth)
        w = out.write
        w("mesh2 {\n  vertex_vectors { %d" % len(pos))
        w("".join(",\n<%s,%s,%s>" % (f(p[0]), f(p[1]), f(p[2])) for p in pos))
        w("\n  }\n  normal_vectors { %d" % len(nrm))
        w("".join(",\n<%s,%s,%s>" % (f(n[0]), f(n[1]), f(n[2])) for n in nrm))
        w("\n  }\n  face_indices { %d" % len(smooth))
        w("".join(",\n<%d,%d,%d>" % t[:3] for t in smooth))
        w("\n  }\n")
        if not same:
            w("  normal_indices { %d" % len(smooth))
            w("".join(",\n<%d,%d,%d>" % t[3:] for t in smooth))
            w("\n  }\n")
        w("  texture { %s }\n}\n" % tex)
    if flat:
        out.write("mesh {\n")
        out.write("".join("  triangle { %s, %s, %s }\n" % (vec(pos[a]), vec(pos[b]), vec(pos[c]))
                          for a, b, c in flat))
        out.write("  texture { %s }\n}\n" % tex)


def area_light(keys, col, name, area):
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
    n overrides the cfg's samples per side (POV-Ray's adaptive mode wants
    2^k + 1); adaptive None writes no `adaptive` (every point sampled).
    """
    corner = get(keys, "corner", None, 3)
    e1 = get(keys, "edge1", None, 3)
    e2 = get(keys, "edge2", None, 3)
    n = area[0] if area and area[0] else int(get(keys, "samples", 4, 1))
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


def convert(cfg, dst, width, height, area=None):
    warnings = []

    def warn(msg):
        warnings.append(msg)
        print("cfg2pov: warning: %s" % msg, file=sys.stderr)

    secs = read_cfg(cfg)
    base = os.path.dirname(os.path.abspath(cfg))
    render = next((s[2] for s in secs if s[0] == "render"), {})
    camera = next((s[2] for s in secs if s[0] == "camera"), {})
    W = width or int(get(render, "width", 640, 1))
    H = height or int(get(render, "height", 480, 1))
    bg = get(render, "background", [0.0, 0.0, 0.0], 3)
    depth = int(get(render, "max_depth", 5, 1))
    gamma = get(render, "gamma", 1.0, 1)
    if get(render, "samples", 1, 1) != 1:
        warn("samples > 1: rendered with -A this is one ray per pixel centre")
    eye = get(camera, "eye", [0.0, 0.0, 5.0], 3)
    target = get(camera, "target", [0.0, 0.0, 0.0], 3)
    up = get(camera, "up", [0.0, 1.0, 0.0], 3)
    fov = get(camera, "fov", 45.0, 1)

    idents = {}
    for kind, name, keys, ln in secs:
        if kind == "material":
            if not name:
                raise Bad("%s:%d: a material needs a name" % (cfg, ln))
            idents[name] = "M_%d" % len(idents)

    tmp = dst + ".tmp"
    with open(tmp, "w") as out:
        out.write("// %s: %s written for POV-Ray 3.7 by bench/cfg2pov.py.\n" % (os.path.basename(dst), cfg))
        out.write("// Render at %dx%d with -A File_Gamma=%s (see the docstring of bench/cfg2pov.py).\n"
                  % (W, H, f(gamma)))
        for msg in warnings:
            out.write("// warning: %s\n" % msg)
        out.write("#version 3.7;\n\nglobal_settings {\n  assumed_gamma 1.0\n  ambient_light rgb 1\n"
                  "  max_trace_level %d\n}\n\n" % max(1, depth))
        out.write("camera {\n  perspective\n  location %s\n  look_at  %s\n  sky      %s\n  up       y\n"
                  "  right    -x*%d/%d\n  angle    2*degrees(atan(%d/%d*tan(radians(%s/2))))\n}\n\n"
                  % (vec(eye), vec(target), vec(up), W, H, W, H, f(fov)))
        out.write("background { rgb %s }\n\n" % vec(bg))

        # A directional light needs a far position: well outside the scene.
        ext = [abs(x) for x in eye + target]
        for kind, name, keys, ln in secs:
            if kind == "sphere":
                c = get(keys, "center", None, 3)
                ext += [abs(x) + get(keys, "radius", None, 1) for x in c]
            elif kind == "light" and get(keys, "type", "point") == "point":
                ext += [abs(x) for x in get(keys, "position", None, 3)]
        far = 1e4 * (max(ext) + 1.0)

        for kind, name, keys, ln in secs:
            if kind != "light":
                continue
            typ = get(keys, "type", "point")
            col = get(keys, "color", [1.0, 1.0, 1.0], 3)
            if typ == "point":
                p = get(keys, "position", None, 3)
                out.write("light_source { %s color rgb %s }  // %s\n" % (vec(p), vec(col), name or ""))
            elif typ == "directional":
                d = get(keys, "direction", None, 3)
                n = math.sqrt(sum(x * x for x in d))
                if n == 0:
                    raise Bad("%s:%d: direction must not be 0" % (cfg, ln))
                at = [-far * x / n for x in d]
                out.write("light_source { %s color rgb %s parallel point_at <0, 0, 0> }  // %s, directional %s\n"
                          % (vec(at), vec(col), name or "", vec(d)))
            elif typ == "area":
                out.write(area_light(keys, col, name, area))
            else:
                raise Bad("%s:%d: %s lights are not supported by cfg2pov" % (cfg, ln, typ))
        out.write("\n")

        for kind, name, keys, ln in secs:
            if kind == "material":
                try:
                    material(name, keys, idents[name], out, warn)
                except Bad as e:
                    raise Bad("%s:%d: %s" % (cfg, ln, e))
        out.write("\n")

        nobj = 0
        for kind, name, keys, ln in secs:
            if kind not in ("sphere", "plane", "triangle", "mesh"):
                if kind not in ("render", "camera", "light", "material"):
                    raise Bad("%s:%d: unknown section [%s]" % (cfg, ln, kind))
                continue
            try:
                mat = get(keys, "material")
                if mat not in idents:
                    raise Bad("no material named '%s'" % mat)
                tex = idents[mat]
                if kind == "sphere":
                    out.write("sphere { %s, %s texture { %s } }\n"
                              % (vec(get(keys, "center", None, 3)), f(get(keys, "radius", None, 1)), tex))
                elif kind == "plane":
                    p = get(keys, "point", None, 3)
                    nv = get(keys, "normal", None, 3)
                    ln_ = math.sqrt(sum(x * x for x in nv))
                    if ln_ == 0:
                        raise Bad("normal must not be 0")
                    nv = [x / ln_ for x in nv]
                    out.write("plane { %s, %s texture { %s } }\n"
                              % (vec(nv), f(sum(a * b for a, b in zip(nv, p))), tex))
                elif kind == "triangle":
                    v = [get(keys, "v%d" % i, None, 3) for i in range(3)]
                    if "n0" in keys:
                        n = [get(keys, "n%d" % i, None, 3) for i in range(3)]
                        out.write("smooth_triangle { %s, %s, %s, %s, %s, %s texture { %s } }\n"
                                  % (vec(v[0]), vec(n[0]), vec(v[1]), vec(n[1]), vec(v[2]), vec(n[2]), tex))
                    else:
                        out.write("triangle { %s, %s, %s texture { %s } }\n" % (vec(v[0]), vec(v[1]), vec(v[2]), tex))
                else:
                    write_mesh(out, keys, base, tex, name)
                nobj += 1
            except Bad as e:
                raise Bad("%s:%d: [%s]: %s" % (cfg, ln, kind, e))
    os.replace(tmp, dst)
    return nobj


def main(argv):
    args = argv[1:]
    width = height = None
    area_n = area_a = None
    pos = []
    i = 0
    while i < len(args):
        a = args[i]
        if a in ("--width", "--height") and i + 1 < len(args):
            v = int(args[i + 1])
            if v < 1:
                sys.exit("cfg2pov: %s must be positive" % a)
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
        elif a in ("-h", "--help"):
            print(__doc__)
            return 0
        else:
            pos.append(a)
            i += 1
    if len(pos) != 2:
        print("usage: cfg2pov.py SCENE.cfg OUT.pov [--width W --height H] [--area-size N] [--area-adaptive A]",
              file=sys.stderr)
        return 2
    try:
        convert(pos[0], pos[1], width, height, (area_n, area_a))
    except (Bad, OSError, UnicodeDecodeError) as e:
        try:
            os.unlink(pos[1] + ".tmp")
        except OSError:
            pass
        print("cfg2pov: %s" % e, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
