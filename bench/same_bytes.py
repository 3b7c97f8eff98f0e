#!/usr/bin/python3
"""Do two rayd builds render the same bytes? Every scene file of scenes/
(*.cfg, *.json), scenes/assignments/ and scenes/extreme/, and every scene
`make bench` renders (bench/rayd_bench/scene_set.py: the generated ones at
their full `make bench` sizes, the million-triangle knot and bumpy sphere
included), through `rayd render` at the scene's own settings (no override;
--limit-objects 2000000, as the bench renders the large ones), then the
bench's own renders of them (scene_set.bench_renders: 1920x1080, one
sample, --packets all, ...); the PNG's sha256 for each binary; the renders
whose PNGs differ are listed.

    python3 bench/same_bytes.py OLD NEW [--work DIR] [--save-old FILE] [--save-new FILE]

OLD and NEW are each a rayd binary, or a manifest written by --save-old or
--save-new (sha256sum's format, "HASH  NAME" a line), so that a build can
be compared with one that is no longer at hand. A one-off measurement, not
a test (tests/integration/same_bytes_test.py is the test, at small sizes,
through the CLI, a daemon and a farm). The generated scenes go to --work
(default build/same-bytes/), made once with the first binary given. Run
from the checkout's root; needs scenes/generated/knot.obj (`make scenes`).
Exit 0 when every scene has the same bytes, 1 when one differs or fails.
"""
import argparse
import hashlib
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench"))
from rayd_bench import scene_set  # noqa: E402


def is_binary(path):
    with open(path, "rb") as f:
        return f.read(4) == b"\x7fELF"


def read_manifest(path):
    out = {}
    with open(path) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                digest, name = line.rstrip("\n").split("  ", 1)
                out[name] = "failed: in the manifest" if digest == "FAILED" else digest
    return out


def render(rayd, path, flags, out_dir):
    """sha256 of `rayd render`'s PNG, or "failed: why"."""
    out = os.path.join(out_dir, "render.png")
    p = subprocess.run([rayd, "render", path, "-o", out, "--quiet"] + list(flags), cwd=ROOT,
                       stdin=subprocess.DEVNULL, capture_output=True, timeout=3600)
    if p.returncode != 0:
        return "failed: exit %d: %s" % (p.returncode, p.stderr.decode("utf-8", "replace").strip()[-300:])
    with open(out, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    os.unlink(out)
    return digest


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("old", help="a rayd binary, or a manifest of one")
    ap.add_argument("new", help="a rayd binary, or a manifest of one")
    ap.add_argument("--work", default=os.path.join(ROOT, "build", "same-bytes"),
                    help="the generated scenes and the renders (default build/same-bytes)")
    ap.add_argument("--save-old", metavar="FILE", help="write OLD's manifest (sha256sum's format) to FILE")
    ap.add_argument("--save-new", metavar="FILE", help="write NEW's manifest to FILE")
    a = ap.parse_args()
    sides = []
    for arg in (a.old, a.new):
        if not os.path.isfile(arg):
            sys.exit("same_bytes: %s: no such file" % arg)
        sides.append(("binary", os.path.abspath(arg)) if is_binary(arg) else ("manifest", read_manifest(arg)))
    binaries = [v for kind, v in sides if kind == "binary"]
    if not binaries:
        sys.exit("same_bytes: give at least one rayd binary (both are manifests)")
    if not os.path.isfile(os.path.join(ROOT, "scenes", "generated", "knot.obj")):
        sys.exit("same_bytes: scenes/generated/knot.obj is missing (make scenes)")
    os.makedirs(a.work, exist_ok=True)
    t0 = time.time()
    print("same_bytes: generating the bench's scenes in %s ..." % a.work, flush=True)
    scenes = scene_set.every_scene(binaries[0], os.path.join(a.work, "gen"), quick=False)
    print("same_bytes: %d scenes generated in %.0f s" % (len(scenes), time.time() - t0), flush=True)
    scenes = [(name, path, list(scene_set.LIMITS)) for name, path in scenes] + scene_set.bench_renders(scenes)
    digests = [{}, {}]
    for i, (kind, v) in enumerate(sides):
        if kind == "manifest":
            digests[i] = v
    differ, failed = [], []
    for name, path, flags in scenes:
        t = time.time()
        for i, (kind, v) in enumerate(sides):
            if kind == "binary":
                digests[i][name] = render(v, path, flags, a.work)
        old, new = digests[0].get(name, "missing"), digests[1].get(name, "missing")
        if any(d.startswith("failed") or d == "missing" for d in (old, new)):
            failed.append(name)
            verdict = "FAILED (old: %s; new: %s)" % (old, new)
        elif old != new:
            differ.append(name)
            verdict = "DIFFERS %s %s" % (old[:16], new[:16])
        else:
            verdict = "same %s" % old[:16]
        print("  %-60s %s  (%.1f s)" % (name, verdict, time.time() - t), flush=True)
    for path, i in ((a.save_old, 0), (a.save_new, 1)):
        if path:
            with open(path, "w") as f:
                for name, _, _ in scenes:
                    d = digests[i].get(name, "missing")
                    f.write("%s  %s\n" % ("FAILED" if d.startswith("failed") or d == "missing" else d, name))
    print("same_bytes: %d renders, %d the same, %d differ%s, %d failed, in %.0f s" %
          (len(scenes), len(scenes) - len(differ) - len(failed), len(differ),
           (": " + ", ".join(differ)) if differ else "", len(failed), time.time() - t0))
    return 1 if differ or failed else 0


if __name__ == "__main__":
    sys.exit(main())
