#!/usr/bin/env python3
"""Jobs outlive the daemon: `rayd serve` killed with SIGKILL and started
again on the same job store, of the engine RAYD_TEST_STORE names
(tests/support/stored_jobs.py): sqlite, the default (`--data-dir DIR`, the
embedded SQLite store), or postgresql (`--store URL`, a PostgreSQL server of
the test's own: tests/support/servers.py). The checks are the same on both.

- 20 asynchronous jobs over several bundled scenes; the daemon is killed
  once some are done and some running, the last one accepted (202) just
  before the kill. Started again on the same --data-dir (same --daemon-id,
  so its old leases are taken back at once), it serves the images of the
  jobs finished before the kill at once, and every one of the 20 ends done
  with an image whose pixels are those of `rayd render` of the same scene
  and overrides.
- One large job of many store tiles (--store-tile 64) is killed mid-way:
  the daemon started again finishes it, rendering fewer tiles than the job
  has (rayd_farm_tiles_total of the new process): the tiles stored before
  the kill were kept, not rendered again.
- Every answer carries X-Rayd-Daemon: the --daemon-id.
- One vocabulary: a synchronous render's job (in memory), a stored job and
  `rayd render --stats-format json` of the same progressive render give
  the same keys for the same figures, with the same values, and the same
  curve of [ms, samples, error] points; POST /v1/render's X-Rayd-* headers
  are its job's figures; a stored job running has its "stats" as a job in
  memory does, and no stopped_by.
- A job whose stamps in the store are changed there directly (sqlite3, or
  psql) reads the durations they make; stamps that went back read
  queued_ms and elapsed_ms 0, not below.

Usage: RAYD=build/rayd /usr/bin/python3 tests/integration/store_test.py
(from the repository root; scenes/generated/knot.obj from `make scenes` adds
mesh.cfg); RAYD_TEST_STORE=postgresql before it for PostgreSQL (the Debian
package postgresql, `make deps`: initdb, pg_ctl and psql). Daemons listen on
127.0.0.1 on ports they pick and are stopped by their pid; the whole run is
bounded by BOUND_S seconds (times RAYD_TEST_SLOW, default 1). It prints `store: N passed, M failed` and
exits 1 on any failure; the temporary folders (data, logs, PostgreSQL's) are
kept then and named.
"""
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from rayd_http import RAYD, Checks, Daemon, cli_render, decode_png, metric_value  # noqa: E402
import stored_jobs  # noqa: E402
from stored_jobs import (JOBS, TILES, Abort, Headers, png_body, query,  # noqa: E402
                         scene_bytes, status_json)

check = Checks("store")
# RAYD_TEST_SLOW=3 (sanitizer builds, say) stretches every wait and the bound.
SLOW = float(os.environ.get("RAYD_TEST_SLOW", "1"))
BOUND_S = int(90 * SLOW)
DAEMON_ID = "store-test"
LEASE_MS = 1500
STORE_TILE = 64
# 64 tiles of 64x64; about 5 s on one core.
BIG = ("area_light.cfg", {"width": 512, "height": 512, "samples": 16})


seen = Headers(check)
STARTED = []  # every daemon, to be stopped whatever happens


def call(d, method, path, body=None, headers=None, timeout=30):
    """A request to d; Abort when it cannot be made (the daemon died)."""
    try:
        status, h, b = d.request(method, path, body=body, headers=headers, timeout=timeout)
    except OSError as e:
        rc = d.proc.poll()
        raise Abort("%s %s: %s%s" % (method, path, e, "" if rc is None else
                                     " (the daemon exited %d): %s" % (rc, d.text()[-800:])))
    seen.saw("%s %s %d" % (method, path, status), h, (DAEMON_ID,))
    return status, h, b


def start(tmp, name, store):
    folder = os.path.join(tmp, name)
    os.makedirs(folder, exist_ok=True)
    flags = store.flags + ["--threads", "2", "--lease-ms", str(LEASE_MS), "--daemon-id", DAEMON_ID,
                           "--store-tile", str(STORE_TILE)]
    try:
        d = Daemon(folder, flags)
    except RuntimeError as e:
        raise Abort("rayd serve %s did not start: %s" % (" ".join(flags), e))
    STARTED.append(d)
    return d


def references(tmp):
    """The CLI's pixels of every job, by (scene, query)."""
    refs = {}
    for scene, ov in JOBS + [BIG]:
        out = os.path.join(tmp, "cli-%d.png" % len(refs))
        refs[(scene, query(ov))] = decode_png(cli_render(os.path.join("scenes", scene), out, ov, ["--threads", "2"]))
    return refs


def submit(d, scene, ov):
    body = scene_bytes(scene)
    status, h, b = call(d, "POST", "/v1/jobs?" + query(ov), body=body, headers={"Content-Type": "text/x-rayd-cfg"})
    try:
        jid = json.loads(b)["id"]
    except (ValueError, KeyError, TypeError):
        jid = None
    ok = check(status == 202 and jid, "POST /v1/jobs %s %s: %d %r" % (scene, query(ov), status, b[:200]))
    if ok:
        check(h.get("location") == "/v1/jobs/" + jid, "the 202's Location is %r" % h.get("location"))
    if not ok:
        raise Abort("no job accepted: nothing else can be checked")
    return jid


def status_of(d, jid):
    status, _, b = call(d, "GET", "/v1/jobs/" + jid)
    return status_json(status, b)


def statuses(d, ids):
    return {jid: status_of(d, jid) for jid in ids}


def image(d, jid):
    return png_body(*call(d, "GET", "/v1/jobs/%s/image" % jid))


def wait_done(d, ids, timeout, what):
    return stored_jobs.wait_done(check, lambda jid: status_of(d, jid), ids, timeout, what)


def same_pixels(png_bytes, ref, what):
    return stored_jobs.same_pixels(check, png_bytes, ref, what)


def tiles_metric(d):
    status, _, body = call(d, "GET", "/metrics")
    return metric_value(body, TILES) if status == 200 else None


def crash_and_restart(tmp, store, refs):
    """The 20 jobs; the kill; every one done after the restart."""
    d1 = start(tmp, "d1", store)
    jobs = {}
    for scene, ov in JOBS[:-1]:
        jobs[submit(d1, scene, ov)] = (scene, ov)
    ids = list(jobs)
    # Kill once some are done and some running.
    deadline, st = time.time() + 30 * SLOW, {}
    while time.time() < deadline:
        st = statuses(d1, ids)
        done = [j for j in ids if st[j].get("status") == "done"]
        running = [j for j in ids if st[j].get("status") == "running"]
        if len(done) >= 4 and running and len(ids) - len(done) >= 4 or len(done) == len(ids):
            break
        time.sleep(0.03)
    before = {j: image(d1, j) for j in ids if st.get(j, {}).get("status") == "done"}
    st = statuses(d1, ids)
    done_before = [j for j in ids if st[j].get("status") == "done"]
    running = [j for j in ids if st[j].get("status") == "running"]
    # The last is accepted just before the kill: its 202 means it is kept.
    last = submit(d1, *JOBS[-1])
    jobs[last] = JOBS[-1]
    rc = d1.kill()
    check(rc == -signal.SIGKILL, "the daemon was killed by SIGKILL (exit %s)" % rc)
    print("store: killed with %d of %d jobs done, %d running" % (len(done_before), len(jobs), len(running)))
    check(done_before and running and len(jobs) - len(done_before) >= 2,
          "the kill came with some jobs done (%d) and some running (%d) of %d" %
          (len(done_before), len(running), len(jobs)))

    d2 = start(tmp, "d2", store)
    status, h, _ = call(d2, "GET", "/healthz")
    check(status == 200, "GET /healthz after the restart: %d" % status)
    for j in done_before:
        png_bytes = image(d2, j)
        check(png_bytes is not None, "the image of job %s, done before the kill, is not served after it" % j)
        if png_bytes is not None and before.get(j) is not None:
            check(png_bytes == before[j], "job %s's PNG changed across the restart" % j)
    final = wait_done(d2, list(jobs), 45 * SLOW, "after the restart")
    for j, (scene, ov) in jobs.items():
        s = final.get(j, {})
        if s.get("status") != "done":
            continue
        check(s.get("width") == ov["width"] and s.get("height") == ov["height"] and s.get("progress") == 1,
              "job %s's status: width %s height %s progress %s" % (j, s.get("width"), s.get("height"),
                                                                   s.get("progress")))
        same_pixels(image(d2, j), refs[(scene, query(ov))], "job %s (%s %s)" % (j, scene, query(ov)))
    check(final.get(last, {}).get("status") == "done", "the job accepted just before the kill was not kept")
    return d2, jobs


def resume(tmp, store, refs, d2, jobs):
    """A large job killed mid-way is finished, not started over."""
    scene, ov = BIG
    tiles = math.ceil(ov["width"] / STORE_TILE) * math.ceil(ov["height"] / STORE_TILE)
    base = tiles_metric(d2)
    check(base is not None, "GET /metrics has no %s" % TILES)
    base = base or 0
    jid = submit(d2, scene, ov)
    deadline, delta, s = time.time() + 30 * SLOW, 0, {}
    while time.time() < deadline:
        delta = (tiles_metric(d2) or 0) - base
        if delta >= tiles // 4:
            break
        time.sleep(0.02)
    s = status_of(d2, jid)
    if s.get("status") == "running":
        check(isinstance(s.get("stats"), dict) and "stopped_by" not in s,
              "a running stored job's status has stats, and no stopped_by, as a job in memory: %s" % s)
    rc = d2.kill()
    print("store: the large job killed at %s with %d of its %d tiles stored (progress %s)" %
          (s.get("status"), delta, tiles, s.get("progress")))
    check(rc == -signal.SIGKILL, "the daemon was killed by SIGKILL (exit %s)" % rc)
    check(delta >= 1 and s.get("status") != "done", "the large job was mid-way at the kill: %d tiles stored, %s" %
          (delta, s.get("status")))
    d3 = start(tmp, "d3", store)
    final = wait_done(d3, [jid], 45 * SLOW, "the large job after the restart").get(jid, {})
    passes = final.get("passes") if isinstance(final.get("passes"), int) and final.get("passes") > 0 else 1
    rendered = tiles_metric(d3)
    print("store: the new process rendered %s tiles of the %d x %d pass(es)" % (rendered, tiles, passes))
    units = tiles * passes
    check(rendered is not None and rendered < units,
          "%s of the new process is %s: not below the job's %d tiles (it started over?)" % (TILES, rendered, units))
    check(rendered is not None and rendered <= units - delta,
          "the new process rendered %s tiles; %d of %d were stored before the kill" % (rendered, delta, units))
    check(rendered is not None and rendered + delta >= units,
          "%s counted %s tiles after the kill and %d before it, of a job of %d" % (TILES, rendered, delta, units))
    if final.get("status") == "done":
        same_pixels(image(d3, jid), refs[(scene, query(ov))], "the resumed job %s" % jid)
    first = next(iter(jobs))
    check(image(d3, first) is not None, "job %s's image is not served after a second restart" % first)
    clock_stepped_back(store, d3, first)
    return d3


# Progressive: passes of 2, 2 and 4 samples, so the curve has three points.
VOCAB = ("area_light.cfg", {"width": 48, "height": 36, "samples": 8, "time_budget_ms": 600000})
# The job's own keys in GET /v1/jobs/{id}; the others are the render's figures.
ENVELOPE = {"id", "status", "progress", "elapsed_ms", "queued_ms", "width", "height"}
SAME = ("samples", "passes", "stopped_by", "camera_rays", "shadow_rays", "secondary_rays", "primitives")


def figures(status):
    """A job status's figures, its stats lifted beside the others."""
    out = {k: v for k, v in status.items() if k not in ENVELOPE and k != "stats"}
    out.update(status.get("stats") or {})
    return out


def curve_points(curve):
    return isinstance(curve, list) and all(isinstance(p, list) and len(p) == 3 and
                                           all(isinstance(x, (int, float)) for x in p) for p in curve)


def one_vocabulary(tmp, d):
    """The CLI, a job in memory and a stored job name each figure alike."""
    scene, ov = VOCAB
    status, h, _ = call(d, "POST", "/v1/render?" + query(ov), body=scene_bytes(scene),
                        headers={"Content-Type": "text/x-rayd-cfg"})
    check(status == 200 and h.get("x-rayd-job"), "POST /v1/render %s: %d, X-Rayd-Job %s" %
          (scene, status, h.get("x-rayd-job")))
    mem = status_of(d, h.get("x-rayd-job", "none"))
    jid = submit(d, scene, ov)
    stored = wait_done(d, [jid], 30 * SLOW, "the vocabulary's job").get(jid, {})
    args = [RAYD, "render", os.path.join("scenes", scene), "-o", os.path.join(tmp, "vocab.png"), "--quiet",
            "--stats-format", "json"] + [a for k, v in ov.items() for a in ("--" + k.replace("_", "-"), str(v))]
    p = subprocess.run(args, capture_output=True, timeout=60)
    try:
        cli = json.loads(p.stderr.decode().splitlines()[-1])
    except (IndexError, ValueError):
        cli = {}
    if not check(mem.get("status") == "done" and stored.get("status") == "done" and cli,
                 "the vocabulary's renders: in memory %s, stored %s, CLI exit %d %r" %
                 (mem.get("status"), stored.get("status"), p.returncode, p.stderr[-300:])):
        return
    check(list(mem) == list(stored) and list(mem.get("stats", {})) == list(stored.get("stats", {})),
          "a job in memory and a stored job have other keys:\n  %s\n  %s" % (mem, stored))
    fm, fs = figures(mem), figures(stored)
    check(set(fm) <= set(cli), "figures of the job status the CLI names otherwise: %s" % sorted(set(fm) - set(cli)))
    check("rays_per_s" not in cli, "the CLI still names rays_per_s: %s" % cli)
    for what, curve in (("in memory", mem.get("curve")), ("stored", stored.get("curve")), ("CLI", cli.get("curve"))):
        check(curve_points(curve) and len(curve) == 3, "%s: the curve is not 3 points [ms, samples, error]: %s" %
              (what, curve))
    for k in SAME:
        check(fm.get(k) == fs.get(k) == cli.get(k), "%s: in memory %s, stored %s, CLI %s" %
              (k, fm.get(k), fs.get(k), cli.get(k)))
    spp = [[p[1] for p in c] if curve_points(c) else None for c in (mem["curve"], stored["curve"], cli["curve"])]
    check(spp[0] == spp[1] == spp[2] == [2, 4, 8], "the curves' samples: %s" % spp)
    check(math.isclose(fm.get("error_estimate", -1), cli.get("error_estimate", -2), rel_tol=1e-9) and
          math.isclose(fs.get("error_estimate", -1), cli.get("error_estimate", -2), rel_tol=1e-9),
          "error_estimate: in memory %s, stored %s, CLI %s" %
          (fm.get("error_estimate"), fs.get("error_estimate"), cli.get("error_estimate")))
    # The headers of the answer are its job's figures, under the spec's names.
    want = {"x-rayd-samples": str(mem.get("samples")), "x-rayd-passes": str(mem.get("passes")),
            "x-rayd-stopped-by": mem.get("stopped_by"), "x-rayd-error-estimate": "%.6f" % mem["error_estimate"],
            "x-rayd-render-ms": "%.3f" % mem["elapsed_ms"]}
    got = {k: h.get(k) for k in want}
    check(got == want, "POST /v1/render's headers %s are not its job's status %s" % (got, want))


def clock_stepped_back(store, d, jid):
    """Durations from wall-clock stamps are never negative: the stamps are
    separate readings of a clock that may step back (a job once read
    queued_ms -2), here made so in the store itself. First stamps that go
    forward, so that the status is seen to read what was written."""
    n = store.execute("UPDATE jobs SET started_ms = submitted_ms + 5000, finished_ms = submitted_ms + 5250 "
                      "WHERE id = ?", jid)
    check(n == 1, "setting job %s's stamps in the %s store changed %d rows, not 1" % (jid, store.engine, n))
    s = status_of(d, jid)
    check(s.get("queued_ms") == 5000 and s.get("elapsed_ms") == 250,
          "a job whose stamps were set 5000 and 5250 ms after its submission reads queued_ms %s, elapsed_ms %s "
          "(want 5000 and 250)" % (s.get("queued_ms"), s.get("elapsed_ms")))
    n = store.execute("UPDATE jobs SET started_ms = submitted_ms - 5, finished_ms = submitted_ms - 7 WHERE id = ?",
                      jid)
    check(n == 1, "setting job %s's stamps back in the %s store changed %d rows, not 1" % (jid, store.engine, n))
    s = status_of(d, jid)
    check(s.get("queued_ms") == 0 and s.get("elapsed_ms") == 0,
          "a job whose stamps went back reads queued_ms %s, elapsed_ms %s (want 0 and 0)" %
          (s.get("queued_ms"), s.get("elapsed_ms")))


def main():
    tmp = tempfile.mkdtemp(prefix="rayd-store-")
    kept, closers = [tmp], []

    def run():
        t = time.time()
        store = stored_jobs.store(tmp, kept, closers)
        print("store: the %s store (%s) in %.1f s" % (store.engine, " ".join(store.flags), time.time() - t))
        t0 = time.time()
        refs = references(tmp)
        t1 = time.time()
        d2, jobs = crash_and_restart(tmp, store, refs)
        t2 = time.time()
        d3 = resume(tmp, store, refs, d2, jobs)
        t3 = time.time()
        one_vocabulary(tmp, d3)
        print("store: the CLI's references took %.1f s, the 20 jobs %.1f s, the large job %.1f s, "
              "the vocabulary %.1f s" % (t1 - t0, t2 - t1, t3 - t2, time.time() - t3))
        seen.report()
        rc = d3.stop()
        check(rc == 0, "the daemon exited %s after SIGTERM" % rc)

    return stored_jobs.bounded_run(check, "store", BOUND_S, run, STARTED, kept, closers,
                                   kept_what="the data and the daemons' logs")


if __name__ == "__main__":
    sys.exit(main())
