#!/usr/bin/env python3
"""Every scene renders to the same bytes whichever way it is rendered.

The scenes: every scene file of scenes/ (*.cfg and their *.json twins),
scenes/assignments/ and scenes/extreme/, and every scene `make bench`
renders (bench/rayd_bench/scene_set.py: the bundled ones it names, and the
large, embree and primitives sections' generated scenes, made by the
bench's own code at the sizes of `make bench-quick`, written to a folder of
the test's own under scenes/generated/ and removed at the end).

The ways, each answering a PNG that must be byte for byte the CLI's:
  - the CLI: `rayd render SCENE -o x.png` of the scene's file;
  - one daemon (`rayd serve --threads 2`, its own SQLite store in
    --data-dir): POST /v1/render, and POST /v1/jobs then GET
    /v1/jobs/ID/image (a stored job, --store-tile 64, the default);
  - a farm: three daemons (`--threads 1` each) on one PostgreSQL of the
    test's own (tests/support/servers.py), --store-tile 24 so that even
    the 33x17 scenes have several tiles and tile edges fall inside the
    queue's 16x16 tiles: a stored job POSTed to each daemon in turn, its
    tiles claimed by whichever daemon asks first, its image read from each
    of the three (each of the three answers the same bytes).
The farm is on PostgreSQL, not on one SQLite folder shared by three daemons:
docs/deploy.md gives SQLite to one daemon on one machine and PostgreSQL to
several daemons sharing one queue, so PostgreSQL is the farm that is
deployed (three daemons on one SQLite folder did share a job's tiles and
gave the same bytes when tried, but that is no deployment the documentation
describes). Tiles by daemon are printed per scene, and every farm daemon
must have stored tiles over the run (each job is claimed tile by tile, so
which daemon takes which tile varies from run to run; the bytes must not).

Assets: an uploaded scene's meshes and textures resolve inside the daemon's
--scenes folder (docs/http-api.md), here the checkout's scenes/. A scene in
a subfolder of it (extreme/flat_bvh.cfg names `file = grid.obj`, beside
it) is sent with each mesh `file` and material `texture` prefixed by that
folder (`file = extreme/grid.obj`), the name the API takes for the same
file; the CLI reads the file as it is.

Sizes: the scenes of scenes/extreme/ render as they are (65x49 pixels at
most). Every other scene renders at SMALL, 161x121 (--width/--height on the
CLI, ?width=&height= for the daemons: the same override table), with its own
samples, depth, gamma and seed. On this two-core machine, loaded, the run
took 16 to 27 s so (32 to 48 s under AddressSanitizer, RAYD_TEST_SLOW=3)
against 153 s with every scene at its own size (`--full`; several times that
under AddressSanitizer), for the same property. 161 and 121 are not
multiples of any tile edge, so every path has partial tiles.
bench/same_bytes.py compares two builds at full size through the CLI.

Usage: RAYD=build/rayd /usr/bin/python3 tests/integration/same_bytes_test.py
(from the repository root; needs scenes/generated/knot.obj, `make scenes`,
and the Debian package postgresql, `make deps`). Every daemon listens on
127.0.0.1 on a port it picks and is stopped by its pid; the run is bounded
by BOUND_S seconds (times RAYD_TEST_SLOW, default 1). It prints one line a
scene and `same bytes: N passed, M failed`, and exits 1 on any failure; the
temporary folders (logs) are kept then and named.
"""
import hashlib
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "support"))
sys.path.insert(0, os.path.join(HERE, "..", "..", "bench"))
from rayd_http import RAYD, Checks, Daemon, decode_png, metric_value  # noqa: E402
import stored_jobs  # noqa: E402
from stored_jobs import TILES, Abort, png_body, query, status_json  # noqa: E402
from rayd_bench import scene_set  # noqa: E402

check = Checks("same bytes")
# RAYD_TEST_SLOW=3 (sanitizer builds) stretches every wait and the bound.
SLOW = float(os.environ.get("RAYD_TEST_SLOW", "1"))
# --full: every scene at its own size instead of SMALL (a measurement of
# several minutes, not what `make check` runs).
FULL = "--full" in sys.argv[1:]
BOUND_S = int((3600 if FULL else 420) * SLOW)
JOB_S = 60 * SLOW
SMALL = {"width": 161, "height": 121}
FARM_TILE = 24
FARM_IDS = ["f1", "f2", "f3"]
SCENES_DIR = os.path.abspath("scenes")
ASSET_CFG = re.compile(r'^(\s*(?:file|texture)\s*=\s*"?)([^"#\s][^"#]*?)("?\s*(?:#.*)?)$', re.M)
ASSET_JSON = re.compile(r'("(?:file|texture)"\s*:\s*")([^"]+)(")')

STARTED = []


def api_text(path):
    """The scene's bytes as POSTed: asset names prefixed by the scene's
    folder under scenes/ (see the module's text)."""
    with open(path, "rb") as f:
        text = f.read().decode("utf-8")
    folder = os.path.relpath(os.path.dirname(os.path.abspath(path)), SCENES_DIR)
    if folder == ".":
        return text.encode("utf-8")
    pattern = ASSET_JSON if path.endswith(".json") else ASSET_CFG
    return pattern.sub(lambda m: m.group(1) + folder + "/" + m.group(2) + m.group(3), text).encode("utf-8")


def overrides(name):
    return {} if FULL or name.startswith("extreme/") else dict(SMALL)


class Endpoint:
    def __init__(self, name, daemon):
        self.name, self.daemon = name, daemon

    def call(self, method, path, body=None, headers=None, timeout=60 * SLOW):
        try:
            return self.daemon.request(method, path, body=body, headers=headers, timeout=timeout)
        except OSError as e:
            rc = self.daemon.proc.poll()
            raise Abort("%s %s to %s: %s%s" % (method, path.split("?")[0], self.name, e,
                                               "" if rc is None else " (it exited %d): %s" %
                                               (rc, self.daemon.text()[-800:])))

    def tiles(self):
        st, _, body = self.call("GET", "/metrics")
        v = metric_value(body, TILES) if st == 200 else None
        if v is None:
            raise Abort("%s: GET /metrics has no %s (%d)" % (self.name, TILES, st))
        return v


def start_daemon(tmp, name, flags):
    folder = os.path.join(tmp, name)
    os.makedirs(folder, exist_ok=True)
    flags = flags + ["--daemon-id", name, "--scenes", SCENES_DIR, "--job-timeout-ms", str(int(JOB_S * 1000))]
    try:
        d = Daemon(folder, flags)
    except RuntimeError as e:
        raise Abort("rayd serve %s did not start: %s" % (" ".join(flags), e))
    STARTED.append(d)
    return Endpoint(name, d)


def submit(ep, body, ctype, q, what):
    st, _, b = ep.call("POST", "/v1/jobs?" + q, body=body, headers={"Content-Type": ctype})
    try:
        jid = json.loads(b)["id"] if st == 202 else None
    except (ValueError, KeyError, TypeError):
        jid = None
    check(jid is not None, "%s: POST /v1/jobs to %s: %d %r" % (what, ep.name, st, b[:300]))
    return jid


def image(ep, jid):
    return png_body(*ep.call("GET", "/v1/jobs/%s/image" % jid)) if jid else None


def digest(data):
    return hashlib.sha256(data).hexdigest()[:12] if data else "none"


def describe(got, ref):
    """Why got is not ref: no image, other pixels, or the same pixels
    encoded otherwise."""
    if got is None:
        return "no PNG"
    try:
        a, b = decode_png(got), decode_png(ref)
    except ValueError as e:
        return "does not decode (%s)" % e
    if a[:2] != b[:2]:
        return "%dx%d, the CLI's is %dx%d" % (a[0], a[1], b[0], b[1])
    if a[2] != b[2]:
        n = sum(1 for x, y in zip(a[2], b[2]) if x != y)
        return "%d of %d samples differ" % (n, len(b[2]))
    return "the same pixels, other bytes (%d against %d)" % (len(got), len(ref))


def one_scene(tmp, n, name, path, lone, farm):
    """All the ways for one scene; (same, tiles per farm daemon)."""
    t0 = time.time()
    ov = overrides(name)
    q = query(ov)
    body = api_text(path)
    ctype = "application/json" if path.endswith(".json") else "text/x-rayd-cfg"
    what = "%s%s" % (name, " ?" + q if q else "")
    before = [ep.tiles() for ep in farm]
    # The stored jobs first, then the CLI and the synchronous render while
    # they run.
    lone_id = submit(lone, body, ctype, q, what)
    front = farm[n % len(farm)]
    farm_id = submit(front, body, ctype, q, what)
    out = os.path.join(tmp, "cli.png")
    args = [RAYD, "render", path, "-o", out, "--quiet"]
    for k, v in ov.items():
        args += ["--" + k.replace("_", "-"), str(v)]
    cli_proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    st, h, sync = lone.call("POST", "/v1/render" + ("?" + q if q else ""), body=body,
                            headers={"Content-Type": ctype})
    if not check(st == 200 and h.get("content-type", "").startswith("image/png"),
                 "%s: POST /v1/render: %d %r" % (what, st, sync[:300])):
        sync = None
    try:
        _, err = cli_proc.communicate(timeout=JOB_S)
    except subprocess.TimeoutExpired:
        cli_proc.kill()
        _, err = cli_proc.communicate()
    cli = None
    if check(cli_proc.returncode == 0, "%s: rayd render exited %s: %s" %
             (what, cli_proc.returncode, err.decode("utf-8", "replace")[-300:])):
        with open(out, "rb") as f:
            cli = f.read()
        os.unlink(out)
    by = {jid: ep for jid, ep in ((lone_id, lone), (farm_id, front)) if jid}
    stored_jobs.wait_done(check, lambda jid: status_json(*by[jid].call("GET", "/v1/jobs/" + jid)[::2]), list(by),
                          JOB_S, what)
    tiles = [ep.tiles() - b for ep, b in zip(farm, before)]
    got = {"POST /v1/render": sync, "the stored job": image(lone, lone_id)}
    for ep in farm:
        got["the farm's job from %s" % ep.name] = image(ep, farm_id)
    same = cli is not None
    if cli is not None:
        for way, data in got.items():
            ok = check(data == cli, "%s: %s is not the CLI's PNG (sha256 %s): %s" %
                       (what, way, digest(cli), describe(data, cli)))
            same = same and ok
    size = "?"
    if cli is not None and farm_id:
        w, h = decode_png(cli)[:2]
        size = "%dx%d" % (w, h)
        # A daemon counts its tile just after storing it: another may end
        # the job in between.
        want, t_end = math.ceil(w / FARM_TILE) * math.ceil(h / FARM_TILE), time.time() + 2 * SLOW
        while sum(tiles) < want and time.time() < t_end:
            time.sleep(0.02)
            tiles = [ep.tiles() - b for ep, b in zip(farm, before)]
        check(sum(tiles) >= want, "%s: the farm daemons stored %d tiles of a job of %d" % (what, sum(tiles), want))
    print("same bytes: %-34s %-7s %s sha256 %s, farm tiles %s (%.2f s)" %
          (name, size, "identical" if same else "DIFFER", digest(cli), "/".join("%d" % t for t in tiles),
           time.time() - t0), flush=True)
    return same, tiles


def main():
    if not os.path.isfile(os.path.join(SCENES_DIR, "generated", "knot.obj")):
        print("FAIL: scenes/generated/knot.obj is missing (make scenes): mesh.cfg cannot render", file=sys.stderr)
        return 1
    tmp = tempfile.mkdtemp(prefix="rayd-same-bytes-")
    gen = tempfile.mkdtemp(prefix="same-bytes-", dir=os.path.join(SCENES_DIR, "generated"))
    kept, closers = [tmp, gen], []

    def run():
        t_start = time.time()
        scenes = scene_set.every_scene(RAYD, gen, quick=True)
        print("same bytes: %d scenes (the bench's generated in %.1f s)" % (len(scenes), time.time() - t_start))
        pg = stored_jobs.postgresql("rayd-same-bytes-pg-", kept, closers)
        lone = start_daemon(tmp, "lone", ["--threads", "2", "--data-dir", os.path.join(tmp, "lone-data")])
        farm = [start_daemon(tmp, i, ["--threads", "1", "--store", pg.url, "--store-tile", str(FARM_TILE)])
                for i in FARM_IDS]
        same, shared, total = 0, 0, [0] * len(farm)
        for n, (name, path) in enumerate(scenes):
            ok, tiles = one_scene(tmp, n, name, path, lone, farm)
            same += ok
            shared += sum(1 for t in tiles if t > 0) >= 2
            total = [a + b for a, b in zip(total, tiles)]
        check(all(t > 0 for t in total), "a farm daemon stored no tile over the run: %s by %s" %
              (total, "/".join(FARM_IDS)))
        print("same bytes: %d of %d scenes the same bytes through the CLI, POST /v1/render, a stored job and a "
              "farm of three; farm tiles by %s: %s, %d jobs shared by two or more; %.0f s" %
              (same, len(scenes), "/".join(FARM_IDS), "/".join("%d" % t for t in total), shared,
               time.time() - t_start))
        for d in list(STARTED):
            rc = d.stop()
            check(rc == 0, "a daemon exited %s after SIGTERM" % rc)

    return stored_jobs.bounded_run(check, "same bytes", BOUND_S, run, STARTED, kept, closers,
                                   kept_what="the logs and the generated scenes")


if __name__ == "__main__":
    sys.exit(main())
