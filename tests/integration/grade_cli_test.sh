#!/bin/sh
# `rayd grade` of a class (docs/grading.md, "Grading a class"): several
# --image or a --dir, a line per student and a summary, the CSV, the exit
# statuses, the reference rendered once, and one --image as it always was.
# Usage: RAYD=build/rayd sh tests/integration/grade_cli_test.sh   (from the repository root)
set -u
RAYD=${RAYD:-build/rayd}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
A="$PWD/scenes/assignments"

# grade ARGS...: rayd grade of phong, stdout in $T/out, stderr in $T/err, status in $rc.
grade() {
    "$RAYD" grade --assignments "$A" --threads 2 "$@" >"$T/out" 2>"$T/err"
    rc=$?
}
# has_line TEXT FILE: FILE has exactly this line.
has_line() { grep -qxF -- "$1" "$2"; }
count() { grep -c -- "$1" "$2"; }

# The class: two correct renderers (the assignment's scene rendered), one
# with shininess halved, one upload that is not a PNG, one of the wrong size.
C="$T/class"
mkdir "$C"
"$RAYD" render "$A/phong.cfg" -o "$C/alice.png" 2>/dev/null || bad "render alice"
cp "$C/alice.png" "$C/=smith, j.png"
sed 's/^shininess = 10$/shininess = 5/' "$A/phong.cfg" >"$T/halved.cfg"
cmp -s "$A/phong.cfg" "$T/halved.cfg" && bad "the halved scene is the assignment's"
"$RAYD" render "$T/halved.cfg" -o "$C/bob.png" 2>/dev/null || bad "render bob"
printf 'GIF89a, not a PNG\n' >"$C/carol.png"
"$RAYD" render "$A/phong.cfg" -o "$C/dave.png" --width 96 --height 72 2>/dev/null || bad "render dave"
printf 'left out\n' >"$C/notes.txt"
cp "$C/alice.png" "$C/.hidden.png"

# --dir: every *.png sorted by name, a line each and the summary; exit 4.
grade --assignment phong --dir "$C" --csv "$T/class.csv"
[ "$rc" -eq 4 ] && ok || bad "--dir with failures: exit $rc, wanted 4; $(cat "$T/err")"
cat >"$T/want" <<'EOF'
student =smith, j: pass failed_fraction=0 max_abs=0 psnr_db=99.00 ssim=1.0000
student alice: pass failed_fraction=0 max_abs=0 psnr_db=99.00 ssim=1.0000
student carol: error: the image is not a PNG file
student dave: error: the image is 96x72; the assignment renders 320x240
summary: 5 students of phong: 2 pass, 1 fail, 2 errors
EOF
grep -v '^student bob: ' "$T/out" >"$T/got"
cmp -s "$T/got" "$T/want" && ok || bad "--dir lines: $(cat "$T/out")"
sed -n 3p "$T/out" | grep -Eq '^student bob: fail failed_fraction=0\.[0-9]+ max_abs=[0-9]+ psnr_db=[0-9.]+ ssim=0\.[0-9]{4}$' &&
    ok || bad "bob's line is not the third, a fail: $(cat "$T/out")"
[ "$(count 'reference rendered' "$T/err")" -eq 1 ] && ok || bad "the reference was not rendered once: $(cat "$T/err")"

# The CSV: its header, a row per student in the lines' order, RFC 4180
# quoting, the formula guard, RFC 3339 times; the metrics are those of
# grading each image alone.
head -n 1 "$T/class.csv" | od -An -c | tr -d ' \n' >"$T/header"
[ "$(cat "$T/header")" = 'student,assignment,pass,failed_fraction,max_abs,psnr_db,ssim,graded_at,grade_id,url,kind,counts,submitted_at,late,score,points,on_roster,regrade_of,error\r\n' ] && ok ||
    bad "CSV header: $(cat "$T/header")"
grade --assignment phong --image "$C/bob.png"
[ "$rc" -eq 4 ] && ok || bad "bob alone: exit $rc, wanted 4"
cp "$T/out" "$T/bob.json"
cat >"$T/check_csv.py" <<'PY'
import csv, datetime, json, re, sys
raw = open(sys.argv[1], "rb").read()
bob = json.load(open(sys.argv[2]))["metrics"]
start, end = float(sys.argv[3]), float(sys.argv[4])
problems = []
def want(cond, what):
    if not cond:
        problems.append(what)
lines = raw.split(b"\r\n")
want(lines[-1] == b"" and all(b"\n" not in l for l in lines), "every line ends in CRLF")
rows = list(csv.reader(open(sys.argv[1], newline="")))
want(len(rows) == 6, "%d records, wanted the header and 5" % len(rows))
want(all(len(r) == 19 for r in rows), "a record without 19 cells: %s" % [len(r) for r in rows])
if not problems:
    body = [dict(zip(rows[0], r)) for r in rows[1:]]
    want([r["student"] for r in body] == ["'=smith, j", "alice", "bob", "carol", "dave"],
         "students: %s" % [r["student"] for r in body])
    want(b'"\'=smith, j",phong,true,' in raw, "the id with a comma quoted, its = guarded")
    want(all(r["assignment"] == "phong" for r in body), "assignment column")
    want([(r["kind"], r["score"], r["points"]) for r in body] == [("image", "1", "1")] * 2 + [("image", "0", "1")] * 3,
         "kind, score and points (phong's 1 point): %s" % [(r["kind"], r["score"], r["points"]) for r in body])
    want(all(r[k] == "" for r in body for k in ("grade_id", "url", "counts", "submitted_at", "late", "on_roster", "regrade_of")),
         "a command's rows are no records: %s" % body[0])
    want([r["pass"] for r in body] == ["true", "true", "false", "false", "false"],
         "pass column: %s" % [r["pass"] for r in body])
    for r in body[:2]:
        want((r["failed_fraction"], r["max_abs"], r["psnr_db"], r["ssim"], r["error"]) == ("0", "0", "99", "1", ""),
             "a passing row: %s" % r)
    b = body[2]
    for k in ("failed_fraction", "psnr_db", "ssim"):
        want(float(b[k]) == bob[k], "bob's %s %s, alone %r" % (k, b[k], bob[k]))
    want(int(b["max_abs"]) == bob["max_abs"] and b["error"] == "", "bob's row: %s" % b)
    want(float(b["failed_fraction"]) > 0.001, "bob passes by the CSV: %s" % b)
    want(body[3]["error"] == "the image is not a PNG file", "carol's error: %s" % body[3])
    want(body[4]["error"] == "the image is 96x72; the assignment renders 320x240", "dave's error: %s" % body[4])
    for r in body[3:]:
        want([r[k] for k in ("failed_fraction", "max_abs", "psnr_db", "ssim")] == [""] * 4,
             "an error row has metrics: %s" % r)
    for r in body:
        m = re.fullmatch(r"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d)\.(\d{3})Z", r["graded_at"])
        want(m is not None, "graded_at %r is not RFC 3339 UTC" % r["graded_at"])
        if m:
            t = datetime.datetime.strptime(m.group(1), "%Y-%m-%dT%H:%M:%S").replace(
                tzinfo=datetime.timezone.utc).timestamp() + int(m.group(2)) / 1000
            want(start - 1 <= t <= end + 1, "graded_at %s is not during the run" % r["graded_at"])
if problems:
    sys.exit("; ".join(problems))
PY
start=$(date +%s)
grade --assignment phong --dir "$C" --csv "$T/class.csv"
end=$(date +%s)
/usr/bin/python3 "$T/check_csv.py" "$T/class.csv" "$T/bob.json" "$start" "$end" 2>"$T/why" && ok ||
    bad "the CSV: $(cat "$T/why")"

# Two --image are two students (a second used to replace the first), in
# the order given; every one passing is exit 0.
grade --assignment phong --image "$C/bob.png" --image "$C/alice.png"
[ "$rc" -eq 4 ] && ok || bad "two --image: exit $rc, wanted 4"
[ "$(count '^student ' "$T/out")" -eq 2 ] && sed -n 1p "$T/out" | grep -q '^student bob: fail ' &&
    sed -n 2p "$T/out" | grep -q '^student alice: pass ' && ok || bad "two --image, both graded: $(cat "$T/out")"
has_line "summary: 2 students of phong: 1 pass, 1 fail, 0 errors" "$T/out" && ok || bad "summary: $(cat "$T/out")"
grade --assignment phong --image "$C/alice.png" --image "$C/=smith, j.png"
[ "$rc" -eq 0 ] && has_line "summary: 2 students of phong: 2 pass, 0 fail, 0 errors" "$T/out" && ok ||
    bad "all pass: exit $rc: $(cat "$T/out")"
# Only error rows: still exit 4, still every row; a missing file is a row too.
grade --assignment phong --image "$C/carol.png" --image "$T/gone.png" --csv "$T/errors.csv"
[ "$rc" -eq 4 ] && ok || bad "only error rows: exit $rc, wanted 4; $(cat "$T/err")"
has_line "student gone: error: $T/gone.png: cannot open: No such file or directory" "$T/out" && ok ||
    bad "a missing image's line: $(cat "$T/out")"
[ "$(grep -c '^carol,phong,false,,,,,.*,the image is not a PNG file' "$T/errors.csv")" -eq 1 ] &&
    [ "$(wc -l <"$T/errors.csv")" -eq 3 ] && ok || bad "error rows' CSV: $(cat "$T/errors.csv")"
[ "$(count 'reference' "$T/err")" -eq 0 ] && ok || bad "no image to compare, yet a reference: $(cat "$T/err")"
# --image and --dir together, --csv with one --image: a class too.
mkdir "$T/class2" && cp "$C/alice.png" "$T/class2/zed.PNG"
grade --assignment phong --image "$C/bob.png" --dir "$T/class2"
[ "$rc" -eq 4 ] && sed -n 2p "$T/out" | grep -q '^student zed: pass ' && ok || bad "--image and --dir: $(cat "$T/out")"
grade --assignment phong --image "$C/alice.png" --csv "$T/one.csv"
[ "$rc" -eq 0 ] && [ "$(wc -l <"$T/one.csv")" -eq 2 ] && grep -q '^alice,phong,true,0,0,99,1,' "$T/one.csv" && ok ||
    bad "--csv with one --image: exit $rc: $(cat "$T/out" "$T/one.csv")"

# The reference is rendered once per run, and with --cache-dir once at all.
grade --assignment phong --dir "$C" --cache-dir "$T/cache"
[ "$(count 'reference rendered' "$T/err")" -eq 1 ] && [ "$(ls "$T/cache" | grep -c '\.png$')" -eq 1 ] && ok ||
    bad "--cache-dir, first run: $(cat "$T/err"); $(ls "$T/cache")"
grade --assignment phong --dir "$C" --cache-dir "$T/cache"
[ "$rc" -eq 4 ] && [ "$(count 'reference rendered' "$T/err")" -eq 0 ] &&
    [ "$(count 'reference read from the cache' "$T/err")" -eq 1 ] && ok ||
    bad "--cache-dir, second run rendered again: $(cat "$T/err")"
has_line "summary: 5 students of phong: 2 pass, 1 fail, 2 errors" "$T/out" && ok || bad "cached run: $(cat "$T/out")"

# A given scene: graded the same, no assignment in the table.
grade --scene "$A/phong.cfg" --image "$C/alice.png" --image "$C/bob.png" --csv "$T/scene.csv"
[ "$rc" -eq 4 ] && has_line "summary: 2 students of $A/phong.cfg: 1 pass, 1 fail, 0 errors" "$T/out" &&
    grep -q '^alice,,true,' "$T/scene.csv" && ok || bad "--scene class: exit $rc: $(cat "$T/out" "$T/scene.csv")"

# One --image alone: the verdict JSON as always, nothing on stderr.
grade --assignment phong --image "$C/alice.png"
[ "$rc" -eq 0 ] && [ ! -s "$T/err" ] && /usr/bin/python3 -c '
import json, sys
o = json.load(open(sys.argv[1]))
assert o["pass"] is True and o["assignment"] == "phong" and "metrics" in o, o' "$T/out" && ok ||
    bad "one --image: exit $rc: $(cat "$T/out" "$T/err")"
grade --assignment phong --image "$C/carol.png"
[ "$rc" -eq 2 ] && [ ! -s "$T/out" ] && has_line "rayd grade: the image is not a PNG file" "$T/err" && ok ||
    bad "one bad --image keeps exit 2: exit $rc: $(cat "$T/err")"

# What ends a class's run is what ends one image's: before any student is
# read, and no CSV.
grade --assignment nosuch --dir "$C" --csv "$T/x.csv"
[ "$rc" -eq 1 ] && [ ! -s "$T/out" ] && [ ! -e "$T/x.csv" ] && grep -q "no assignment named 'nosuch'" "$T/err" && ok ||
    bad "unknown assignment: exit $rc: $(cat "$T/out" "$T/err")"
mkdir "$T/broken"
cp "$A/phong.cfg" "$T/broken/broken.cfg"
printf 'fail = three\n' >"$T/broken/broken.grade"
"$RAYD" grade --assignments "$T/broken" --assignment broken --dir "$C" --csv "$T/x.csv" >"$T/out" 2>"$T/err"
rc=$?
[ "$rc" -eq 2 ] && [ ! -s "$T/out" ] && [ ! -e "$T/x.csv" ] && ok || bad "a broken assignment: exit $rc: $(cat "$T/err")"
grade --assignment phong --dir "$C" --csv "$T/no/such/x.csv"
[ "$rc" -eq 3 ] && [ ! -s "$T/out" ] && grep -q "cannot write" "$T/err" && ok ||
    bad "an unwritable --csv is found first: exit $rc: $(cat "$T/out" "$T/err")"
grade --assignment phong --dir "$T/nosuch"
[ "$rc" -eq 3 ] && ok || bad "a missing --dir: exit $rc, wanted 3"
mkdir "$T/empty"
grade --assignment phong --dir "$T/empty"
[ "$rc" -eq 1 ] && grep -q "no \*.png" "$T/err" && ok || bad "an empty --dir: exit $rc: $(cat "$T/err")"
grade --assignment phong --image "$C/alice.png" --image "$T/class2/../class/alice.png"
[ "$rc" -eq 1 ] && [ ! -s "$T/out" ] && grep -q "both student 'alice'" "$T/err" && ok ||
    bad "one student twice: exit $rc: $(cat "$T/err")"
grade --assignment phong --dir "$C" --diff "$T/d.png"
[ "$rc" -eq 1 ] && [ ! -e "$T/d.png" ] && ok || bad "--diff of a class: exit $rc"

# --help explains the class's flags.
"$RAYD" grade --help >"$T/out"
for opt in "--dir FOLDER" "--csv OUT.csv" "give it again"; do
    grep -q -- "$opt" "$T/out" && ok || bad "grade --help does not explain $opt"
done

echo "grade cli: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
