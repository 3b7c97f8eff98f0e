#!/bin/sh
# cfg and JSON are one scene model: for every bundled scene, the checked-in
# JSON twin is what `rayd convert` makes of the cfg, converting back and forth
# is stable, and both spellings render byte-identical PNGs.
# Usage: RAYD=build/rayd sh tests/integration/formats_test.sh   (from the repository root)
set -u
RAYD=${RAYD:-build/rayd}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
pass=0
fail=0
check() { if "$@"; then pass=$((pass + 1)); else fail=$((fail + 1)); echo "FAIL: $*"; fi; }

for cfg in scenes/*.cfg; do
    n=$(basename "$cfg" .cfg)
    json=scenes/$n.json
    check test -f "$json"
    "$RAYD" convert "$cfg" "$T/$n.json" 2>"$T/err" || echo "convert $cfg: $(cat "$T/err")"
    check cmp -s "$T/$n.json" "$json"
    "$RAYD" convert "$json" "$T/$n.back.cfg" 2>/dev/null
    "$RAYD" convert "$cfg" "$T/$n.canon.cfg" 2>/dev/null
    check cmp -s "$T/$n.back.cfg" "$T/$n.canon.cfg"
    "$RAYD" convert "$T/$n.canon.cfg" "$T/$n.again.json" 2>/dev/null
    check cmp -s "$T/$n.again.json" "$json"
    "$RAYD" render "$cfg" -o "$T/$n.cfg.png" --width 120 --height 90 --samples 3 2>/dev/null
    "$RAYD" render "$json" -o "$T/$n.json.png" --width 120 --height 90 --samples 3 2>/dev/null
    check test -s "$T/$n.cfg.png"
    check cmp -s "$T/$n.cfg.png" "$T/$n.json.png"
done
# Every JSON twin has its cfg.
for json in scenes/*.json; do
    check test -f "scenes/$(basename "$json" .json).cfg"
done
echo "formats: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
