#!/bin/sh
# End-to-end checks of the rayd command line: exit codes, messages, files.
# Usage: RAYD=build/rayd sh tests/integration/cli_test.sh   (from the repository root)
set -u
RAYD=${RAYD:-build/rayd}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }

# expect_exit CODE DESCRIPTION -- command...
expect_exit() {
    want=$1; what=$2; shift 3
    "$@" >"$T/out" 2>"$T/err"
    got=$?
    if [ "$got" -eq "$want" ]; then ok; else bad "$what: exit $got, wanted $want; stderr: $(head -c 300 "$T/err")"; fi
}

# PNG signature, then IHDR width, height, bit depth 8 and colour type 2 (RGB).
png_is() {
    f=$1; w=$2; h=$3
    sig=$(od -An -tx1 -N8 "$f" | tr -d ' \n')
    ihdr=$(od -An -tx1 -j16 -N10 "$f" | tr -d ' \n')
    want=$(printf '%08x%08x0802' "$w" "$h")
    [ "$sig" = "89504e470d0a1a0a" ] && [ "$ihdr" = "$want" ]
}

expect_exit 0 "rayd --help" -- "$RAYD" --help
grep -q "render SCENE" "$T/out" && ok || bad "rayd --help does not list render"
expect_exit 0 "rayd render --help" -- "$RAYD" render --help
for opt in --width --height --samples --threads --seed -o; do
    grep -q -- "$opt" "$T/out" && ok || bad "render --help does not explain $opt"
done
expect_exit 1 "no command" -- "$RAYD"
expect_exit 1 "unknown command" -- "$RAYD" paint
expect_exit 1 "render without -o" -- "$RAYD" render scenes/phong.cfg
expect_exit 1 "render without scene" -- "$RAYD" render -o "$T/x.png"
expect_exit 1 "render --width 0" -- "$RAYD" render scenes/phong.cfg -o "$T/x.png" --width 0
expect_exit 1 "render --samples x" -- "$RAYD" render scenes/phong.cfg -o "$T/x.png" --samples x
expect_exit 1 "unknown option" -- "$RAYD" render scenes/phong.cfg -o "$T/x.png" --colour red
[ ! -e "$T/x.png" ] && ok || bad "a usage error wrote an image"

# A scene error: exit 2, the located message, and no image.
printf '[render]\nwidth = 64O\n' >"$T/bad.cfg"
expect_exit 2 "scene error" -- "$RAYD" render "$T/bad.cfg" -o "$T/bad.png"
grep -q "bad.cfg:2:9: width: expected an integer in 1..16384, got '64O'" "$T/err" && ok ||
    bad "scene error message: $(cat "$T/err")"
[ ! -e "$T/bad.png" ] && ok || bad "a scene error wrote an image"
printf '[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = flor\n' >"$T/inv.cfg"
expect_exit 2 "unknown material" -- "$RAYD" render "$T/inv.cfg" -o "$T/inv.png"

# I/O errors: exit 3.
expect_exit 3 "missing scene file" -- "$RAYD" render "$T/nope.cfg" -o "$T/n.png"
expect_exit 3 "unwritable output" -- "$RAYD" render scenes/diffuse.cfg -o "$T/no/such/dir/x.png" --width 8 --height 8

# The other commands' usage errors and limits: the same exit codes.
expect_exit 1 "serve: bad number" -- "$RAYD" serve --threads x
grep -q -- "--threads: expected an integer in 1..1024, got 'x'" "$T/err" && ok || bad "serve --threads x: $(cat "$T/err")"
expect_exit 1 "serve: bad --listen" -- "$RAYD" serve --listen nowhere
expect_exit 1 "serve: unknown option" -- "$RAYD" serve --colour red
expect_exit 0 "--version" -- "$RAYD" --version
cp "$T/out" "$T/version1"
grep -Eq '^rayd [0-9]+\.[0-9]+\.[0-9]+' "$T/out" && ok || bad "--version prints 'rayd X.Y.Z...': $(cat "$T/out")"
expect_exit 0 "version" -- "$RAYD" version
cmp -s "$T/out" "$T/version1" && ok || bad "rayd version and rayd --version differ"
expect_exit 0 "serve --help" -- "$RAYD" serve --help
grep -q -- "--memory-budget N" "$T/out" && grep -q "(default 64; RAYD_QUEUE)" "$T/out" && ok || bad "serve --help lacks flags or defaults"
expect_exit 0 "limits" -- "$RAYD" limits
grep -q -- "--limit-samples *65536" "$T/out" && ok || bad "rayd limits: $(head -c 300 "$T/out")"
grep -q -- "--max-samples *65536" "$T/out" && bad "rayd limits lists the old names" || ok
expect_exit 1 "converge: --max-samples is its last row" -- "$RAYD" converge scenes/diffuse.cfg --max-samples 0
grep -q -- "--max-samples: expected an integer in 1..65536" "$T/err" && ok || bad "converge --max-samples 0: $(cat "$T/err")"
expect_exit 2 "converge: a limit applies" -- "$RAYD" converge scenes/diffuse.cfg --limit-pixels 100
grep -q -- "--limit-pixels" "$T/err" && ok || bad "converge limit message: $(cat "$T/err")"
expect_exit 1 "converge: --width out of range" -- "$RAYD" converge scenes/diffuse.cfg --width 0
grep -q "expected an integer in 1..16384" "$T/err" && ok || bad "converge --width 0: $(cat "$T/err")"
expect_exit 0 "schema" -- "$RAYD" schema
grep -q '"\$schema"' "$T/out" && ok || bad "rayd schema printed no JSON Schema"

# Every bundled scene renders, as an RGB PNG of its size, with no NaN.
for f in scenes/*.cfg; do
    n=$(basename "$f" .cfg)
    expect_exit 0 "render $f" -- "$RAYD" render "$f" -o "$T/$n.png" --width 96 --height 72
    png_is "$T/$n.png" 96 72 && ok || bad "$n.png is not a 96x72 8-bit RGB PNG"
    grep -q "nonfinite=0" "$T/err" && ok || bad "$f: non-finite samples: $(cat "$T/err")"
done

# The statistics line has every field.
"$RAYD" render scenes/phong.cfg -o "$T/s.png" --width 32 --height 24 --samples 4 2>"$T/err"
grep -Eq '^render: 32x24 samples=4 threads=[0-9]+ time_ms=[0-9.]+ camera_rays=3072 shadow_rays=[0-9]+ secondary_rays=0 rays_per_second=[0-9.e+]+ error_estimate=[0-9.]+ nonfinite=0 prepare_ms=[0-9.]+ bvh_build_ms=[0-9.]+ bvh_nodes=[0-9]+ primitives=4 world_bytes=[0-9]+ stopped_by=samples passes=1 curve=[0-9.]+:4:[0-9.]+$' "$T/err" &&
    ok || bad "statistics line: $(cat "$T/err")"

# Same bytes whatever the thread count.
"$RAYD" render scenes/perfect_specular.cfg -o "$T/t1.png" --width 80 --height 60 --samples 4 --threads 1 2>/dev/null
"$RAYD" render scenes/perfect_specular.cfg -o "$T/t2.png" --width 80 --height 60 --samples 4 --threads 2 2>/dev/null
cmp -s "$T/t1.png" "$T/t2.png" && ok || bad "1 and 2 threads give different images"

# A different seed changes a multi-sample image; the same seed does not.
"$RAYD" render scenes/phong.cfg -o "$T/a.png" --width 40 --height 30 --samples 4 --seed 1 2>/dev/null
"$RAYD" render scenes/phong.cfg -o "$T/b.png" --width 40 --height 30 --samples 4 --seed 2 2>/dev/null
"$RAYD" render scenes/phong.cfg -o "$T/c.png" --width 40 --height 30 --samples 4 --seed 1 2>/dev/null
cmp -s "$T/a.png" "$T/b.png" && bad "seed does not change the image" || ok
cmp -s "$T/a.png" "$T/c.png" && ok || bad "same seed gives a different image"

# --stats-format json: one JSON object with every figure of the text line.
# "both" prints the line and then the object for the same render, so every
# figure (times too) can be checked against the line, formatted as it is.
cat >"$T/stats_check.py" <<'PY'
import json, sys
lines = open(sys.argv[1]).read().splitlines()
text = [l for l in lines if l.startswith("render: ")]
objs = [l for l in lines if l.startswith("{")]
if len(text) != 1 or len(objs) != 1:
    sys.exit("want one text line and one JSON line, got %d and %d" % (len(text), len(objs)))
o = json.loads(objs[0])
t = text[0][len("render: "):].split(" ")
size, kv = t[0], dict(f.split("=", 1) for f in t[1:])
fmt = {"time_ms": "%.3f", "rays_per_second": "%.4g", "error_estimate": "%.6f", "prepare_ms": "%.3f",
       "bvh_build_ms": "%.3f"}
bad = []
if size != "%dx%d" % (o["width"], o["height"]):
    bad.append("size %s against %sx%s" % (size, o["width"], o["height"]))
for k, v in kv.items():
    if k not in o:
        bad.append("%s: in the text line, not in the JSON" % k)
    elif k == "curve":
        got = ",".join("%.3f:%s:%.6f" % (ms, "%g" % spp, e) for ms, spp, e in o["curve"])
    elif k == "stopped_by":
        got = o[k]
    elif k in fmt:
        got = fmt[k] % o[k]
    else:
        got = "%d" % o[k] if o[k] == int(o[k]) else repr(o[k])
    if got != v:
        bad.append("%s: text %s, JSON %s" % (k, v, got))
want = set(kv) | {"width", "height", "mean_samples"}
if set(o) != want:
    bad.append("JSON keys differ from the line's: %s" % sorted(set(o) ^ want))
if bad:
    sys.exit("; ".join(bad))
PY
"$RAYD" render scenes/area_light.cfg -o "$T/j.png" --width 40 --height 30 --time-budget-ms 200 --stats-format both 2>"$T/err"
/usr/bin/python3 "$T/stats_check.py" "$T/err" 2>"$T/why" && ok || bad "--stats-format both: $(cat "$T/why")"
"$RAYD" render scenes/mesh.cfg -o "$T/j.png" --width 32 --height 24 --samples 2 --stats-format both 2>"$T/err"
/usr/bin/python3 "$T/stats_check.py" "$T/err" 2>"$T/why" && ok || bad "--stats-format both, mesh: $(cat "$T/why")"
# json alone: the object is the only line, and nothing else changes.
"$RAYD" render scenes/phong.cfg -o "$T/j1.png" --width 32 --height 24 --samples 4 --stats-format json 2>"$T/err"
[ "$(wc -l <"$T/err")" -eq 1 ] && /usr/bin/python3 -c '
import json, sys
o = json.load(open(sys.argv[1]))
assert (o["width"], o["height"], o["samples"], o["camera_rays"], o["primitives"]) == (32, 24, 4, 3072, 4), o
assert o["stopped_by"] == "samples" and o["passes"] == 1 and len(o["curve"]) == 1, o
# The daemon'"'"'s names and curve shape (GET /v1/jobs/{id}), not the old rays_per_s and {ms, samples, error}.
assert "rays_per_s" not in o and o["rays_per_second"] > 0, o
assert all(isinstance(p, list) and len(p) == 3 and p[1] == 4 for p in o["curve"]), o
' "$T/err" && ok || bad "--stats-format json: $(cat "$T/err")"
"$RAYD" render scenes/phong.cfg -o "$T/j2.png" --width 32 --height 24 --samples 4 2>/dev/null
cmp -s "$T/j1.png" "$T/j2.png" && ok || bad "--stats-format json changes the image"
expect_exit 1 "--stats-format xml" -- "$RAYD" render scenes/phong.cfg -o "$T/j3.png" --stats-format xml
grep -q "stats-format: expected text, json or both" "$T/err" && ok || bad "--stats-format xml message: $(cat "$T/err")"
# --packets: the same PNG and ray counts as ray by ray, on a mesh (a BVH),
# with 2 samples a pixel and a size no block divides; a bad value is a
# usage error that names the choices.
"$RAYD" render scenes/mesh.cfg -o "$T/p0.png" --width 37 --height 29 --samples 2 --threads 2 2>"$T/e0"
for how in camera shadow all; do
    "$RAYD" render scenes/mesh.cfg -o "$T/p1.png" --width 37 --height 29 --samples 2 --threads 2 --packets "$how" \
        2>"$T/e1"
    cmp -s "$T/p0.png" "$T/p1.png" && ok || bad "--packets $how changes the image"
    c0=$(grep -o 'camera_rays=2146 shadow_rays=[0-9]*' "$T/e0")
    [ -n "$c0" ] && [ "$c0" = "$(grep -o 'camera_rays=[0-9]* shadow_rays=[0-9]*' "$T/e1")" ] && ok ||
        bad "--packets $how changes the counts: $(cat "$T/e1")"
done
expect_exit 1 "--packets some" -- "$RAYD" render scenes/mesh.cfg -o "$T/p2.png" --packets some
grep -q "packets: expected camera, shadow, all or none" "$T/err" && ok || bad "--packets some message: $(cat "$T/err")"
expect_exit 0 "rayd render --help" -- "$RAYD" render --help
grep -q -- "--stats-format" "$T/out" && ok || bad "render --help does not explain --stats-format"

# rayd compare: how two PNGs differ, as JSON.
cmpjson() {  # file expression: the python expression over o must hold
    /usr/bin/python3 -c 'import json, sys; o = json.load(open(sys.argv[1])); sys.exit(0 if eval(sys.argv[2]) else 1)' "$1" "$2"
}
expect_exit 0 "compare --help" -- "$RAYD" compare --help
grep -q "psnr_db" "$T/out" && ok || bad "compare --help does not explain psnr_db"
expect_exit 0 "compare identical" -- "$RAYD" compare "$T/a.png" "$T/c.png"
cmpjson "$T/out" 'o["identical"] is True and o["psnr_db"] == 99 and "psnr" not in o and o["rmse"] == 0 and o["max_diff"] == 0 and o["differing_pixels"] == 0 and (o["width"], o["height"]) == (40, 30)' &&
    ok || bad "compare of identical images: $(cat "$T/out")"
expect_exit 0 "compare different" -- "$RAYD" compare "$T/a.png" "$T/b.png"
cmpjson "$T/out" 'o["identical"] is False and 0 < o["rmse"] < 1 and 0 < o["psnr_db"] < 99 and 0 < o["max_diff"] <= 255 and 0 < o["differing_pixels"] <= 1200' &&
    ok || bad "compare of different images: $(cat "$T/out")"
# A PNG written by hand (grey, 2x2, one pixel 51 levels off): exact values.
/usr/bin/python3 - "$T" <<'PY'
import struct, sys, zlib
def png(path, ctype, rows):
    raw = b"".join(b"\0" + bytes(r) for r in rows)
    def chunk(k, d):
        return struct.pack(">I", len(d)) + k + d + struct.pack(">I", zlib.crc32(k + d))
    w = len(rows[0]) // (1 if ctype == 0 else 3)
    ihdr = struct.pack(">IIBBBBB", w, len(rows), 8, ctype, 0, 0, 0)
    open(path, "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
d = sys.argv[1]
png(d + "/g1.png", 0, [[100, 100], [100, 100]])
png(d + "/g2.png", 2, [[100, 100, 100, 100, 151, 100], [100, 100, 100, 100, 100, 100]])
PY
expect_exit 0 "compare grey with RGB" -- "$RAYD" compare "$T/g1.png" "$T/g2.png"
cmpjson "$T/out" 'abs(o["rmse"] - 51 / (255 * 12 ** 0.5)) < 1e-15 and abs(o["psnr_db"] - 24.771212547196626) < 1e-9 and o["max_diff"] == 51 and o["differing_pixels"] == 1 and o["differing_pixels_over_1"] == 1' &&
    ok || bad "compare of the 2x2 pair: $(cat "$T/out")"
expect_exit 1 "compare one image" -- "$RAYD" compare "$T/a.png"
expect_exit 1 "compare three images" -- "$RAYD" compare "$T/a.png" "$T/b.png" "$T/c.png"
expect_exit 1 "compare unknown option" -- "$RAYD" compare "$T/a.png" "$T/b.png" --fast
expect_exit 1 "compare bad limit" -- "$RAYD" compare "$T/a.png" "$T/b.png" --limit-pixels x
expect_exit 2 "compare sizes differ" -- "$RAYD" compare "$T/a.png" "$T/s.png"
grep -q "sizes differ" "$T/err" && ok || bad "compare size message: $(cat "$T/err")"
expect_exit 2 "compare over --limit-pixels" -- "$RAYD" compare "$T/a.png" "$T/b.png" --limit-pixels 100
grep -q -- "--limit-pixels" "$T/err" && ok || bad "compare limit message: $(cat "$T/err")"
printf 'not a png at all' >"$T/junk.png"
expect_exit 2 "compare not a PNG" -- "$RAYD" compare "$T/a.png" "$T/junk.png"
head -c 100 "$T/a.png" >"$T/cut.png"
expect_exit 2 "compare truncated PNG" -- "$RAYD" compare "$T/cut.png" "$T/a.png"
grep -q "cut.png" "$T/err" && ok || bad "compare names the bad file: $(cat "$T/err")"
: >"$T/empty.png"
expect_exit 2 "compare empty file" -- "$RAYD" compare "$T/empty.png" "$T/a.png"
expect_exit 3 "compare missing file" -- "$RAYD" compare "$T/a.png" "$T/nope.png"
expect_exit 3 "compare a folder" -- "$RAYD" compare "$T/a.png" "$T"

# rayd convert --expand: every key, and meshes as rayd loaded them.
expect_exit 0 "convert --expand" -- "$RAYD" convert scenes/phong.cfg "$T/px.json" --expand
/usr/bin/python3 -c '
import json, sys
o = json.load(open(sys.argv[1]))
assert o["render"]["seed"] == 0 and o["camera"]["up"] == [0, 1, 0] and o["render"]["gamma"] == 1, o["render"]
assert all("kd" in m and "ambient" in m for m in o["materials"].values()), o["materials"]
' "$T/px.json" && ok || bad "convert --expand does not write the defaults: $(head -c 300 "$T/px.json")"
"$RAYD" render "$T/px.json" -o "$T/px.png" --width 40 --height 30 2>/dev/null
"$RAYD" render scenes/phong.cfg -o "$T/pc.png" --width 40 --height 30 2>/dev/null
cmp -s "$T/px.png" "$T/pc.png" && ok || bad "the expanded scene renders differently"
expect_exit 0 "convert --expand mesh" -- "$RAYD" convert scenes/mesh.cfg "$T/mx.json" --expand
"$RAYD" render scenes/mesh.cfg -o "$T/mx.png" --width 8 --height 6 --stats-format json 2>"$T/mx.err"
/usr/bin/python3 -c '
import json, sys
o = json.load(open(sys.argv[1]))
st = json.loads(open(sys.argv[2]).read().splitlines()[-1])
m = [x for x in o["objects"] if x["type"] == "mesh"][0]["loaded"]
np, nn = len(m["positions"]), len(m["normals"])
assert len(m["faces"]) + 1 == st["primitives"], (len(m["faces"]), st["primitives"])
assert all(len(f) == 6 and 0 <= min(f[:3]) and max(f[:3]) < np and -1 <= min(f[3:]) and max(f[3:]) < nn
           for f in m["faces"])
' "$T/mx.json" "$T/mx.err" && ok || bad "convert --expand: the mesh is not the one rayd renders"
expect_exit 2 "an expanded mesh is not read back" -- "$RAYD" render "$T/mx.json" -o "$T/mx2.png"
expect_exit 2 "convert --expand over --limit-objects" -- "$RAYD" convert scenes/mesh.cfg "$T/mx3.json" --expand --limit-objects 1000
grep -q -- "--limit-objects" "$T/err" && ok || bad "convert --expand limit message: $(cat "$T/err")"
expect_exit 1 "convert --expand to cfg" -- "$RAYD" convert scenes/phong.cfg "$T/px.cfg" --expand

# The size limits are --limit-NAME; the old --max-NAME still works, with a
# warning, but --max-depth is now the render override.
expect_exit 2 "an old limit name still applies" -- "$RAYD" render scenes/phong.cfg -o "$T/l.png" --max-pixels 100
grep -q -- "warning: --max-pixels is deprecated.*use --limit-pixels" "$T/err" && grep -q -- "(--limit-pixels)" "$T/err" &&
    ok || bad "old limit name: $(cat "$T/err")"
expect_exit 1 "a bad limit value" -- "$RAYD" render scenes/phong.cfg -o "$T/l.png" --limit-pixels=x
grep -q -- "--limit-pixels: expected a positive integer, got 'x'" "$T/err" && ok || bad "limit value: $(cat "$T/err")"
expect_exit 2 "--limit-depth" -- "$RAYD" render scenes/phong.cfg -o "$T/l.png" --limit-depth 1 --max-depth 2
grep -q "max_depth 2, over the limit of 1 (--limit-depth)" "$T/err" && ok || bad "--limit-depth: $(cat "$T/err")"
expect_exit 1 "--max-depth is the override" -- "$RAYD" render scenes/phong.cfg -o "$T/l.png" --max-depth 65
grep -q -- "--max-depth: expected an integer in 0..64, got '65'" "$T/err" && ! grep -q deprecated "$T/err" && ok ||
    bad "--max-depth 65: $(cat "$T/err")"

# Every override of the query is a flag, and --set render.KEY=VALUE the same.
expect_exit 0 "rayd render --help" -- "$RAYD" render --help
for opt in --gamma --max-depth --seed --set --limit- --progress --quiet .exr .pfm; do
    grep -q -- "$opt" "$T/out" && ok || bad "render --help does not explain $opt"
done
r() { "$RAYD" render scenes/perfect_specular.cfg --width 40 --height 30 "$@" 2>"$T/err"; }
r -o "$T/o0.png"
r -o "$T/o1.png" --max-depth 0 --gamma 2.2
r -o "$T/o2.png" --set render.max_depth=0 --set=render.gamma=2.2
r -o "$T/o3.png" --max-depth=0 --gamma=2.2
cmp -s "$T/o1.png" "$T/o2.png" && cmp -s "$T/o1.png" "$T/o3.png" && ok || bad "--set and the flags give different images"
cmp -s "$T/o0.png" "$T/o1.png" && bad "--max-depth 0 --gamma 2.2 change nothing" || ok
expect_exit 1 "--gamma 0" -- "$RAYD" render scenes/phong.cfg -o "$T/g.png" --gamma 0
grep -q -- "--gamma: expected a number > 0, got '0'" "$T/err" && ok || bad "--gamma 0: $(cat "$T/err")"
expect_exit 1 "--set of another section" -- "$RAYD" render scenes/phong.cfg -o "$T/g.png" --set camera.fov=30
expect_exit 1 "--set of a key that cannot be overridden" -- "$RAYD" render scenes/phong.cfg -o "$T/g.png" --set render.background=1
grep -q "render.background: not a render setting that can be overridden (these can: width, height" "$T/err" && ok ||
    bad "--set render.background: $(cat "$T/err")"
[ ! -e "$T/g.png" ] && ok || bad "a bad override wrote an image"
expect_exit 1 "grade: overrides with an assignment" -- "$RAYD" grade --assignment phong --image "$T/o0.png" --gamma 2
expect_exit 1 "converge sets the samples itself" -- "$RAYD" converge scenes/diffuse.cfg --samples 4

# Outputs: - is stdout; only .png, .exr and .pfm; an unwritable output is
# found before the render, and nothing half-written is left.
"$RAYD" render scenes/phong.cfg -o - --width 32 --height 24 >"$T/stdout.png" 2>"$T/err"
"$RAYD" render scenes/phong.cfg -o "$T/file.png" --width 32 --height 24 2>/dev/null
cmp -s "$T/stdout.png" "$T/file.png" && grep -q "^render: 32x24" "$T/err" && ok || bad "-o - is not the PNG on stdout"
# A special file is written in place, never renamed over (as root a
# rename would replace /dev/null with a regular file).
"$RAYD" render scenes/phong.cfg -o /dev/null --width 32 --height 24 2>"$T/err" && [ -c /dev/null ] && ok ||
    bad "-o /dev/null: $(cat "$T/err"); /dev/null is $(ls -la /dev/null)"
mkfifo "$T/fifo"
cat "$T/fifo" >"$T/fifo.png" &
"$RAYD" render scenes/phong.cfg -o "$T/fifo" --width 32 --height 24 2>"$T/err"
wait
cmp -s "$T/fifo.png" "$T/file.png" && [ -p "$T/fifo" ] && ok || bad "-o FIFO does not write the PNG through it: $(cat "$T/err")"
expect_exit 1 "an output rayd does not write" -- "$RAYD" render scenes/phong.cfg -o "$T/x.jpg"
grep -q -- "-o $T/x.jpg: rayd writes .png, .exr, .pfm (or - for a PNG on stdout)" "$T/err" && ok ||
    bad "unknown extension message: $(cat "$T/err")"
expect_exit 1 "an output without an extension" -- "$RAYD" render scenes/phong.cfg -o "$T/x"
expect_exit 3 "a missing folder" -- "$RAYD" render scenes/phong.cfg -o "$T/no/such/x.png"
grep -q "$T/no/such/x.png: cannot write" "$T/err" && ! grep -q "^render: " "$T/err" && ok ||
    bad "missing folder found after rendering: $(cat "$T/err")"
mkdir "$T/ro" "$T/dir.png"
expect_exit 3 "a folder as output" -- "$RAYD" render scenes/phong.cfg -o "$T/dir.png" --width 8 --height 8
if [ "$(id -u)" -ne 0 ]; then
    chmod 555 "$T/ro"
    expect_exit 3 "a read-only folder" -- "$RAYD" render scenes/phong.cfg -o "$T/ro/x.exr"
    grep -q "$T/ro/x.exr: cannot write: Permission denied" "$T/err" && ! grep -q "^render: " "$T/err" && ok ||
        bad "read-only folder: $(cat "$T/err")"
    chmod 755 "$T/ro"
fi
[ -z "$(ls "$T/ro")" ] && [ -z "$(ls "$T" | grep '\.tmp')" ] && ok || bad "a failed output left files: $(ls "$T" "$T/ro")"

# .pfm and .exr hold the linear image (no --gamma: refused for them): the
# PNG is exactly its clamp, gamma and rounding (rd_display8), and the EXR's
# floats are the PFM's.
"$RAYD" render scenes/area_light.cfg -o "$T/h.png" --width 24 --height 18 --samples 8 --gamma 2.2 2>/dev/null
"$RAYD" render scenes/area_light.cfg -o "$T/h.pfm" --width 24 --height 18 --samples 8 2>/dev/null
"$RAYD" render scenes/area_light.cfg -o "$T/h.exr" --width 24 --height 18 --samples 8 2>/dev/null
/usr/bin/python3 - "$T/h.pfm" "$T/h.png" "$T/h.exr" <<'PY' && ok || bad "the PFM is not the PNG's linear image"
import math, struct, sys, zlib
pfm = open(sys.argv[1], "rb").read()
head = pfm.split(b"\n", 3)
assert head[0] == b"PF" and head[1] == b"24 18" and head[2] == b"-1", head[:3]
floats = struct.unpack("<%df" % (24 * 18 * 3), head[3])
png = open(sys.argv[2], "rb").read()
idat, i = b"", 8
while i < len(png):
    n, kind = struct.unpack(">I4s", png[i:i + 8])
    if kind == b"IDAT":
        idat += png[i + 8:i + 8 + n]
    i += 12 + n
raw, rows, prev = zlib.decompress(idat), [], bytearray(72)
for y in range(18):  # undo the PNG filters
    f, line = raw[y * 73], bytearray(raw[y * 73 + 1:(y + 1) * 73])
    for x in range(72):
        a = line[x - 3] if x >= 3 else 0
        b, c = prev[x], prev[x - 3] if x >= 3 else 0
        p = a + b - c
        pr = a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else b if abs(p - b) <= abs(p - c) else c
        line[x] = (line[x] + [0, a, b, (a + b) // 2, pr][f]) & 255
    rows.append(line)
    prev = line
lit = 0
for y in range(18):
    for i in range(72):
        v = floats[(17 - y) * 72 + i]  # PFM rows run bottom to top
        want = math.floor(min(max(v, 0.0), 1.0) ** (1 / 2.2) * 255 + 0.5)
        assert rows[y][i] == want, (y, i, v, rows[y][i], want)
        lit += v > 0
assert lit > 100, lit
exr = open(sys.argv[3], "rb").read()
assert exr[:4] == b"\x76\x2f\x31\x01" and b"zip" not in exr[:0], exr[:4]
PY

# Progress: one line per pass when stderr is not a terminal and the render
# has several passes, none for one pass or with --quiet; --progress draws
# the bar once the render has run for a second.
"$RAYD" render scenes/area_light.cfg -o "$T/p.png" --width 40 --height 30 --samples 16 --target-error 0.0001 2>"$T/err"
[ "$(grep -c '^render pass [0-9]*: samples=[0-9.]* error=[0-9.]* ms=[0-9.]*$' "$T/err")" -eq 4 ] && ok ||
    bad "pass lines: $(cat "$T/err")"
grep -q "passes=4 " "$T/err" && ok || bad "pass lines of a 4-pass render: $(cat "$T/err")"
"$RAYD" render scenes/area_light.cfg -o "$T/p.png" --width 40 --height 30 --samples 16 --target-error 0.0001 --quiet 2>"$T/err"
[ "$(wc -l <"$T/err")" -eq 1 ] && grep -q "^render: 40x30" "$T/err" && ok || bad "--quiet: $(cat "$T/err")"
"$RAYD" render scenes/area_light.cfg -o "$T/p.png" --width 40 --height 30 --samples 16 2>"$T/err"
[ "$(wc -l <"$T/err")" -eq 1 ] && ok || bad "a one-pass render printed more than its statistics: $(cat "$T/err")"
"$RAYD" render scenes/area_light.cfg -o "$T/p.png" --width 200 --height 150 --samples 128 --progress 2>"$T/err"
ms=$(sed -n 's/.* time_ms=\([0-9]*\).*/\1/p' "$T/err")
if [ "${ms:-0}" -gt 1300 ]; then
    grep -q "$(printf '\r')render \[.*\] *[0-9]*% pass 1 tiles [0-9]*/[0-9]* spp [0-9.]* err [0-9.]* [0-9.]*s left [0-9.]*s" "$T/err" &&
        grep -q "\[####################\] 100% pass 1 tiles 130/130 spp 128.0 err 0.0" "$T/err" && ok ||
        bad "--progress bar: $(cat -v "$T/err")"
fi

# A misspelt command or assignment is told the name it missed (the scene
# reader's did-you-mean); an unknown one far from any lists them.
"$RAYD" render scenes/phong.cfg -o "$T/dym.png" --width 8 --height 8 2>/dev/null
echo '// not graded' >"$T/dym.h"
expect_exit 1 "misspelt command" -- "$RAYD" rendr scenes/phong.cfg -o "$T/x.png"
grep -q "unknown command 'rendr'; did you mean 'render'?" "$T/err" && ok || bad "rayd rendr: $(head -3 "$T/err")"
expect_exit 1 "misspelt assignment" -- "$RAYD" grade --assignments scenes/assignments --assignment phongg \
    --image "$T/dym.png"
grep -q "no assignment named 'phongg'; did you mean 'phong'?" "$T/err" && ok || bad "--assignment phongg: $(cat "$T/err")"
expect_exit 1 "misspelt code assignment" -- "$RAYD" grade --assignments scenes/assignments --assignment difuse \
    --code "$T/dym.h"
grep -q "no assignment named 'difuse'; did you mean 'diffuse'?" "$T/err" && ok || bad "--code --assignment difuse: $(cat "$T/err")"
expect_exit 1 "unknown assignment" -- "$RAYD" grade --assignments scenes/assignments --assignment zzzzzzzz \
    --image "$T/dym.png"
grep -q "no assignment named 'zzzzzzzz' (there are: .*phong" "$T/err" && ok || bad "--assignment zzzzzzzz: $(cat "$T/err")"

# --gamma with a linear output would change nothing in the file: refused
# before rendering, whichever way it is given.
for out in x.exr x.pfm; do
    expect_exit 1 "--gamma with $out" -- "$RAYD" render scenes/phong.cfg -o "$T/$out" --gamma 2.2 --width 8 --height 8
    grep -q -- "--gamma: an* .* holds the linear image" "$T/err" && [ ! -e "$T/$out" ] && ok || bad "--gamma -o $out: $(cat "$T/err")"
    expect_exit 1 "--set render.gamma with $out" -- "$RAYD" render scenes/phong.cfg -o "$T/$out" \
        --set render.gamma=2.2 --width 8 --height 8
done
expect_exit 0 "--gamma with a PNG" -- "$RAYD" render scenes/phong.cfg -o "$T/g.png" --gamma 2.2 --width 8 --height 8
expect_exit 0 "an EXR without --gamma" -- "$RAYD" render scenes/phong.cfg -o "$T/g.exr" --width 8 --height 8

# The README's grading example, as written: render the assignment's scene,
# then grade it.
case $RAYD in /*) bin=$RAYD ;; *) bin=$PWD/$RAYD ;; esac
(cd "$T" && "$bin" render "$OLDPWD/scenes/assignments/phong.cfg" -o my_phong.png 2>/dev/null &&
    "$bin" grade --assignments "$OLDPWD/scenes/assignments" --assignment phong --image my_phong.png --diff where.png >grade.json)
[ $? -eq 0 ] && cmpjson "$T/grade.json" 'o["pass"] is True' && png_is "$T/where.png" 320 240 && ok ||
    bad "the README's grade example: $(cat "$T/grade.json")"

# A perfect grade and a compare of the same two images agree on PSNR, and
# the grade names no worst pixel (there is none).
"$RAYD" compare "$T/my_phong.png" "$T/my_phong.png" >"$T/same.json" 2>/dev/null
/usr/bin/python3 -c 'import json, sys
g, c = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
sys.exit(0 if g["metrics"]["psnr_db"] == c.get("psnr_db") == 99 and g["metrics"]["max_abs"] == 0 and g["worst"] is None else 1)' \
    "$T/grade.json" "$T/same.json" && ok ||
    bad "a perfect grade against compare: grade $(tr -d ' \n\t' <"$T/grade.json" | head -c 400) compare $(cat "$T/same.json")"

echo "cli: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
