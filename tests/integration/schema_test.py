#!/usr/bin/python3
"""The JSON Schema in docs/ against the parser's own answers.

1. docs/scene.schema.json is exactly what `rayd schema` prints (generated
   from the parser's key table, so it cannot drift).
2. It is a valid draft 2020-12 schema, and every scenes/*.json satisfies it.
3. On hand-made and on randomly mutated scenes, schema and parser agree:
   whatever the schema rejects, the parser rejects; whatever the parser
   accepts, the schema accepts; where the schema accepts and the parser
   rejects, the parser's reason is one a schema cannot express (unknown
   material name, degenerate geometry, duplicate name).

Usage: RAYD=build/rayd /usr/bin/python3 tests/integration/schema_test.py
"""
import copy
import glob
import json
import os
import random
import subprocess
import sys
import tempfile

import jsonschema

RAYD = os.environ.get("RAYD", "build/rayd")
PARSER_ONLY = ("no material named", "must not be the zero vector", "must differ from eye",
               "must not be parallel", "duplicate light name", "duplicate material name",
               "duplicate sphere name", "duplicate plane name", "duplicate triangle name",
               "OBJ meshes are not supported")
passed = failed = 0


def check(ok, what):
    global passed, failed
    if ok:
        passed += 1
    else:
        failed += 1
        print("FAIL:", what)


def parse(scene, tmp):
    """(accepted, message) from the real parser via `rayd convert`."""
    path = os.path.join(tmp, "s.json")
    with open(path, "w") as f:
        json.dump(scene, f)
    r = subprocess.run([RAYD, "convert", path, "-", "--to", "cfg"], capture_output=True, text=True)
    if r.returncode not in (0, 2):
        return None, "exit %d: %s" % (r.returncode, r.stderr)
    return r.returncode == 0, r.stderr.strip()


def agree(validator, scene, tmp, what):
    schema_ok = validator.is_valid(scene)
    parser_ok, msg = parse(scene, tmp)
    if parser_ok is None:
        check(False, "%s: parser crashed or failed: %s" % (what, msg))
    elif not schema_ok:
        check(not parser_ok, "%s: schema rejects, parser accepts" % what)
    elif not parser_ok:
        check(any(p in msg for p in PARSER_ONLY), "%s: schema accepts, parser rejects: %s" % (what, msg))
    else:
        check(True, what)
    return schema_ok, parser_ok


def main():
    out = subprocess.run([RAYD, "schema"], capture_output=True, text=True, check=True).stdout
    with open("docs/scene.schema.json") as f:
        check(f.read() == out, "docs/scene.schema.json differs from `rayd schema`")
    schema = json.loads(out)
    jsonschema.Draft202012Validator.check_schema(schema)
    v = jsonschema.Draft202012Validator(schema)
    scenes = sorted(glob.glob("scenes/*.json"))
    check(len(scenes) > 0, "no scenes/*.json")
    for path in scenes:
        with open(path) as f:
            errs = list(v.iter_errors(json.load(f)))
        check(not errs, "%s: %s" % (path, errs[0].message if errs else ""))

    base = json.load(open("scenes/phong.json"))
    with tempfile.TemporaryDirectory() as tmp:
        hand = [
            ("unknown top-level key", lambda s: s.update(rendr={})),
            ("width 0", lambda s: s["render"].update(width=0)),
            ("width 16385", lambda s: s["render"].update(width=16385)),
            ("width 64.5", lambda s: s["render"].update(width=64.5)),
            ("width string", lambda s: s["render"].update(width="640")),
            ("samples 65537", lambda s: s["render"].update(samples=65537)),
            ("max_depth 65", lambda s: s["render"].update(max_depth=65)),
            ("gamma 0", lambda s: s["render"].update(gamma=0)),
            ("seed -1", lambda s: s["render"].update(seed=-1)),
            ("fov 180", lambda s: s["camera"].update(fov=180)),
            ("eye 2 numbers", lambda s: s["camera"].update(eye=[0, 1])),
            ("eye == target", lambda s: s["camera"].update(eye=[0, 1, 0])),
            ("light unknown type", lambda s: s["lights"][0].update(type="sun")),
            ("point light with direction", lambda s: s["lights"][0].update(direction=[0, -1, 0])),
            ("point light without position", lambda s: s["lights"][0].pop("position")),
            ("spot light angle 91", lambda s: s["lights"][0].update(type="spot", direction=[0, -1, 0], angle=91)),
            ("spot light ok", lambda s: s["lights"][0].update(type="spot", direction=[0, -1, 0], angle=40)),
            ("area light ok", lambda s: s["lights"].append(
                {"type": "area", "corner": [0, 5, 0], "edge1": [1, 0, 0], "edge2": [0, 0, 1], "samples": 2})),
            ("area light no edge2", lambda s: s["lights"].append(
                {"type": "area", "corner": [0, 5, 0], "edge1": [1, 0, 0]})),
            ("directional zero direction", lambda s: s["lights"].append(
                {"type": "directional", "direction": [0, 0, 0]})),
            ("material without type", lambda s: s["materials"]["red"].pop("type")),
            ("diffuse with shininess", lambda s: s["materials"]["floor"].update(shininess=3)),
            ("phong misspelt key", lambda s: s["materials"]["red"].update(shinyness=3)),
            ("cook_torrance roughness 0", lambda s: s["materials"].update(ct={"type": "cook_torrance", "roughness": 0})),
            ("cook_torrance ok", lambda s: s["materials"].update(ct={"type": "cook_torrance", "roughness": 1})),
            ("glass ior 0", lambda s: s["materials"].update(g={"type": "specular_refraction", "ior": 0})),
            ("textured_phong without texture", lambda s: s["materials"].update(t={"type": "textured_phong"})),
            ("object without type", lambda s: s["objects"][0].pop("type")),
            ("object type sphre", lambda s: s["objects"][0].update(type="sphre")),
            ("sphere radius 0", lambda s: s["objects"][0].update(radius=0)),
            ("sphere radius -1", lambda s: s["objects"][0].update(radius=-1)),
            ("sphere with normal", lambda s: s["objects"][0].update(normal=[0, 1, 0])),
            ("sphere without material", lambda s: s["objects"][0].pop("material")),
            ("unknown material", lambda s: s["objects"][0].update(material="flor")),
            ("plane zero normal", lambda s: s["objects"][-1].update(normal=[0, 0, 0])),
            ("triangle ok", lambda s: s["objects"].append(
                {"type": "triangle", "v0": [0, 0, 0], "v1": [1, 0, 0], "v2": [0, 1, 0], "material": "red"})),
            ("triangle uv 3 numbers", lambda s: s["objects"].append(
                {"type": "triangle", "v0": [0, 0, 0], "v1": [1, 0, 0], "v2": [0, 1, 0], "material": "red",
                 "uv0": [0, 0, 0], "uv1": [1, 0], "uv2": [0, 1]})),
            ("lights not an array", lambda s: s.update(lights={})),
            ("objects not an array", lambda s: s.update(objects={})),
            ("empty scene", lambda s: [s.pop(k) for k in list(s)]),
            ("duplicate light names", lambda s: s["lights"][1].update(name="key")),
        ]
        expect = {"spot light ok": True, "area light ok": True, "cook_torrance ok": True,
                  "triangle ok": True, "empty scene": True}
        for what, mutate in hand:
            s = copy.deepcopy(base)
            mutate(s)
            _, parser_ok = agree(v, s, tmp, what)
            check(parser_ok == expect.get(what, False), "%s: parser %s" % (what, "accepts" if parser_ok else "rejects"))

        # Random single mutations of every scene: schema and parser agree.
        rng = random.Random(12345)
        values = [0, -1, 1, 0.5, 1e9, 16385, 65537, "x", "", [0, 0], [0, 0, 0], [1, 2, 3, 4], {}, None, True, [0, "a", 1]]
        for i in range(200):
            s = json.load(open(rng.choice(scenes)))
            section = rng.choice(["render", "camera", "lights", "materials", "objects"])
            if section in ("render", "camera"):
                target = s.setdefault(section, {})
            elif section == "materials":
                target = s["materials"][rng.choice(sorted(s["materials"]))]
            else:
                target = rng.choice(s[section])
            keys = sorted(target) + ["width", "radius", "kd", "ks", "normal", "position", "fov", "type", "bogus"]
            key = rng.choice(keys)
            if rng.random() < 0.2 and key in target:
                del target[key]
            else:
                target[key] = copy.deepcopy(rng.choice(values))
            agree(v, s, tmp, "mutation %d (%s.%s)" % (i, section, key))

    print("schema: %d passed, %d failed" % (passed, failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
