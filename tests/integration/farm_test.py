#!/usr/bin/env python3
"""A render farm: three `rayd serve --store postgresql://...` daemons on
one PostgreSQL 15 of the test's own, nginx in front of them
(deploy/nginx/rayd.conf, tests/support/servers.py).

- 20 asynchronous jobs POSTed through nginx: each one's status and image
  are read from a daemon other than the one that accepted it (its 202's
  X-Rayd-Daemon); every job ends done, its PNG the same bytes from each of
  the three daemons and the pixels of `rayd render` of the same scene and
  overrides.
- One large job is rendered by all three (each one's rayd_farm_tiles_total
  grows); one is killed with SIGKILL mid-way; the other two finish it once
  its leases (--lease-ms) run out. Its PNG is byte for byte that of the
  same job rendered by a lone daemon on a SQLite store, and its pixels
  those of `rayd render`.
- DELETE through one daemon cancels a job, seen cancelled through another.
- The store down (PostgreSQL stopped for about 3 s): POST /v1/jobs answers
  503 with Retry-After, /readyz 503, a synchronous POST /v1/render still
  200 with the right PNG. PostgreSQL started again: /readyz is 200 within
  15 s without touching the daemons, the jobs accepted before the stop end
  done and a new job is accepted and done.
- Every daemon's every answer carries X-Rayd-Daemon: its --daemon-id.

Usage: RAYD=build/rayd /usr/bin/python3 tests/integration/farm_test.py
(from the repository root; needs the Debian packages postgresql and nginx,
make deps; $RAYD_NGINX_CONF names another site file). Every server listens
on 127.0.0.1 on a port the test picks and is stopped by its pid; the run is
bounded by BOUND_S seconds (times RAYD_TEST_SLOW, default 1). It prints
`farm: N passed, M failed` and exits 1 on any failure; the temporary
folders (logs) are kept then and named.
"""
import json
import math
import os
import signal
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from rayd_http import Checks, Daemon, cli_render, decode_png, http_request, metric_value  # noqa: E402
import stored_jobs  # noqa: E402
from stored_jobs import (ENDED, JOBS, TILES, Abort, Headers, png_body, query,  # noqa: E402
                         scene_bytes, status_json)
from servers import Nginx  # noqa: E402

check = Checks("farm")
# RAYD_TEST_SLOW=3 (sanitizer builds, say) stretches every wait and the bound.
SLOW = float(os.environ.get("RAYD_TEST_SLOW", "1"))
BOUND_S = int(120 * SLOW)
LEASE_MS = 2000
STORE_TILE = 64
IDS = ["d1", "d2", "d3"]

# 80 tiles of 64x64; about 6 s on one core.
BIG = ("area_light.cfg", {"width": 640, "height": 480, "samples": 16})
# Progressive and adaptive to a target error: 12 tiles a pass, each pass
# ended (estimate, schedule, adaptive weights) by whichever daemon completes it.
PROG = ("area_light.cfg", {"width": 256, "height": 192, "samples": 32, "target_error": 0.002})
# Cancelled long before it could end (minutes).
LONG = ("area_light.cfg", {"width": 640, "height": 480, "samples": 1024})


seen = Headers(check)


class Endpoint:
    """A daemon (its id) or nginx (any of the ids) to send requests to."""

    def __init__(self, name, port, want, proc=None, daemon=None):
        self.name, self.port, self.want, self.proc, self.daemon = name, port, want, proc, daemon

    def call(self, method, path, body=None, headers=None, timeout=30):
        try:
            status, h, b = http_request("127.0.0.1", self.port, method, path, body, headers, timeout)
        except OSError as e:
            rc = self.proc.poll() if self.proc else None
            tail = self.daemon.text()[-800:] if self.daemon else ""
            raise Abort("%s %s to %s: %s%s" % (method, path, self.name, e,
                                               "" if rc is None else " (it exited %d): %s" % (rc, tail)))
        seen.saw("%s %s %s %d" % (self.name, method, path, status), h, self.want)
        return status, h, b


STARTED = []  # every daemon, to be stopped whatever happens


def start_daemon(tmp, daemon_id, store_flags, threads=1):
    folder = os.path.join(tmp, daemon_id)
    os.makedirs(folder, exist_ok=True)
    flags = store_flags + ["--threads", str(threads), "--lease-ms", str(LEASE_MS), "--daemon-id", daemon_id,
                           "--store-tile", str(STORE_TILE)]
    try:
        d = Daemon(folder, flags)
    except RuntimeError as e:
        raise Abort("rayd serve %s did not start: %s" % (" ".join(flags), e))
    STARTED.append(d)
    return Endpoint(daemon_id, d.port, [daemon_id], d.proc, d)


def references(tmp):
    """The CLI's pixels of every job, by (scene, query)."""
    refs = {}
    for scene, ov in JOBS + [BIG]:
        out = os.path.join(tmp, "cli-%d.png" % len(refs))
        refs[(scene, query(ov))] = decode_png(cli_render(os.path.join("scenes", scene), out, ov, ["--threads", "2"]))
    scene, ov = PROG
    out = os.path.join(tmp, "cli-prog.png")
    refs["prog"] = decode_png(cli_render(os.path.join("scenes", scene), out, ov, ["--threads", "2", "--adaptive"]))
    return refs


def progressive_across(ds, refs):
    """A progressive adaptive job on all three: the CLI's pixels."""
    scene, ov = PROG
    base = [tiles_metric(ep) or 0 for ep in ds]
    jid, _, _ = submit(ds[1], scene, dict(ov, adaptive=1))
    final = wait_done({jid: ds[2]}, 60 * SLOW, "the progressive job").get(jid, {})
    delta = [(tiles_metric(ep) or 0) - b for ep, b in zip(ds, base)]
    print("farm: the progressive job: %s passes, %s samples, stopped by %s; tiles by %s: %s" %
          (final.get("passes"), final.get("samples"), final.get("stopped_by"), "/".join(IDS), delta))
    check(final.get("passes", 0) >= 3 and len(final.get("curve", [])) == final.get("passes"),
          "the progressive job ran %s passes with a curve of %s points" % (final.get("passes"), final.get("curve")))
    check(sum(1 for x in delta if x > 0) >= 2, "the progressive job's tiles were all rendered by one daemon: %s" % delta)
    if final.get("status") == "done":
        same_pixels(image(ds[0], jid), refs["prog"], "the progressive adaptive job %s" % jid)


def submit(ep, scene, ov, must=True):
    """POST /v1/jobs: (job id or None, status, headers)."""
    status, h, b = ep.call("POST", "/v1/jobs?" + query(ov), body=scene_bytes(scene),
                           headers={"Content-Type": "text/x-rayd-cfg"})
    try:
        jid = json.loads(b)["id"] if status == 202 else None
    except (ValueError, KeyError, TypeError):
        jid = None
    if must:
        ok = check(status == 202 and jid, "POST /v1/jobs %s %s to %s: %d %r" % (scene, query(ov), ep.name, status,
                                                                               b[:200]))
        if ok:
            check(h.get("location") == "/v1/jobs/" + jid, "the 202's Location is %r" % h.get("location"))
        else:
            raise Abort("no job accepted: nothing else can be checked")
    return jid, status, h


def status_of(ep, jid):
    return status_json(*ep.call("GET", "/v1/jobs/" + jid)[::2])


def image(ep, jid):
    return png_body(*ep.call("GET", "/v1/jobs/%s/image" % jid))


def wait_done(by, timeout, what):
    """by: {job id: endpoint to ask}."""
    return stored_jobs.wait_done(check, lambda jid: status_of(by[jid], jid), list(by), timeout, what)


def same_pixels(png_bytes, ref, what):
    return stored_jobs.same_pixels(check, png_bytes, ref, what)


def tiles_metric(ep):
    status, _, body = ep.call("GET", "/metrics")
    return metric_value(body, TILES) if status == 200 else None


def through_nginx(ds, front, refs):
    """20 jobs in through nginx, read back from the other daemons."""
    by_id = {ep.name: ep for ep in ds}
    jobs, other, accepted = {}, {}, {}
    for scene, ov in JOBS:
        jid, _, h = submit(front, scene, ov)
        jobs[jid] = (scene, ov)
        who = h.get("x-rayd-daemon")
        accepted[who] = accepted.get(who, 0) + 1
        check(who in by_id, "the 202 through nginx named daemon %r" % who)
        other[jid] = next(ep for ep in ds if ep.name != who) if who in by_id else ds[0]
        # Committed before the 202: another daemon knows it at once.
        s = status_of(other[jid], jid)
        check(s.get("status") in ("queued", "running", "done"),
              "job %s, accepted by %s, read from %s just after its 202: %s" % (jid, who, other[jid].name,
                                                                               s.get("status")))
    print("farm: the 20 jobs were accepted by %s" % accepted)
    check(len([w for w in accepted if w in by_id]) >= 2, "nginx sent every job to one daemon: %s" % accepted)
    final = wait_done(other, 60 * SLOW, "the jobs sent through nginx")
    for jid, (scene, ov) in jobs.items():
        if final[jid].get("status") != "done":
            continue
        pngs = {ep.name: image(ep, jid) for ep in ds}
        first = pngs[other[jid].name]
        check(all(p is not None for p in pngs.values()),
              "job %s's image is not served by %s" % (jid, [n for n, p in pngs.items() if p is None]))
        check(len({p for p in pngs.values() if p is not None}) <= 1,
              "job %s's PNG differs between daemons (%s bytes)" % (jid, {n: len(p or b"") for n, p in pngs.items()}))
        same_pixels(first, refs[(scene, query(ov))], "job %s (%s %s)" % (jid, scene, query(ov)))


def shared_job(tmp, ds, refs):
    """The large job on all three; one killed mid-way; the others finish
    it; its PNG is a lone daemon's."""
    scene, ov = BIG
    tiles = math.ceil(ov["width"] / STORE_TILE) * math.ceil(ov["height"] / STORE_TILE)
    base = [tiles_metric(ep) for ep in ds]
    check(all(b is not None for b in base), "GET /metrics has no %s: %s" % (TILES, base))
    base = [b or 0 for b in base]
    jid, _, _ = submit(ds[0], scene, ov)
    deadline, delta, s = time.time() + 40 * SLOW, [0, 0, 0], {}
    while time.time() < deadline:
        delta = [(tiles_metric(ep) or 0) - b for ep, b in zip(ds, base)]
        if all(x >= 1 for x in delta) and sum(delta) >= tiles // 4:
            break
        if status_of(ds[0], jid).get("status") in ENDED:
            break
        time.sleep(0.03)
    s = status_of(ds[0], jid)
    victim = ds[2]
    rc = victim.daemon.kill()
    print("farm: tiles stored by %s when %s was killed: %s of %d (%s)" %
          ("/".join(IDS), victim.name, delta, tiles, s.get("status")))
    check(rc == -signal.SIGKILL, "%s was killed by SIGKILL (exit %s)" % (victim.name, rc))
    check(all(x >= 1 for x in delta), "%s did not grow on every daemon: %s" % (TILES, dict(zip(IDS, delta))))
    check(s.get("status") not in ENDED and sum(delta) < tiles,
          "the large job was not mid-way at the kill: %s, %d of %d tiles" % (s.get("status"), sum(delta), tiles))
    alive = ds[:2]
    final = wait_done({jid: alive[0]}, 40 * SLOW, "the large job after %s died" % victim.name).get(jid, {})
    after = [(tiles_metric(ep) or 0) - b for ep, b in zip(alive, base)]
    print("farm: tiles stored by %s at the end: %s" % ("/".join(IDS[:2]), after))
    check(sum(after) > sum(delta[:2]), "the survivors stored no tile after the kill: %s then %s" % (delta[:2], after))
    check(sum(after) + delta[2] >= tiles, "the daemons stored %d tiles of a job of %d" % (sum(after) + delta[2], tiles))
    if final.get("status") != "done":
        return
    pngs = [image(ep, jid) for ep in alive]
    check(pngs[0] is not None and pngs[0] == pngs[1], "the large job's PNG differs between %s and %s" % tuple(IDS[:2]))
    same_pixels(pngs[0], refs[(scene, query(ov))], "the large job %s" % jid)
    # The same job on a lone daemon with its own SQLite store.
    lone = start_daemon(tmp, "lone", ["--data-dir", os.path.join(tmp, "lone-data")], threads=2)
    lone_id, _, _ = submit(lone, scene, ov)
    lone_final = wait_done({lone_id: lone}, 40 * SLOW, "the large job on a lone daemon").get(lone_id, {})
    if lone_final.get("status") == "done":
        alone = image(lone, lone_id)
        check(alone is not None and alone == pngs[0],
              "the large job's PNG from the farm (%d bytes) is not the lone daemon's (%d bytes)" %
              (len(pngs[0] or b""), len(alone or b"")))
    rc = lone.daemon.stop()
    check(rc == 0, "the lone daemon exited %s after SIGTERM" % rc)


def cancel_across(ds):
    """DELETE through one daemon; cancelled as seen by another."""
    a, b = ds[0], ds[1]
    jid, _, _ = submit(a, *LONG)
    deadline = time.time() + 10
    while time.time() < deadline and status_of(b, jid).get("status") not in ("running",) + ENDED:
        time.sleep(0.05)
    status, _, body = b.call("DELETE", "/v1/jobs/" + jid)
    check(status == 200, "DELETE through %s: %d %r" % (b.name, status, body[:200]))
    t0, s = time.time(), {}
    while time.time() < t0 + 10:
        s = status_of(a, jid)
        if s.get("status") in ENDED:
            break
        time.sleep(0.05)
    check(s.get("status") == "cancelled", "the job DELETEd through %s is %s on %s" % (b.name, s.get("status"), a.name))
    print("farm: cancelled through %s, seen on %s after %.2f s" % (b.name, a.name, time.time() - t0))
    status, _, _ = a.call("GET", "/v1/jobs/%s/image" % jid)
    check(status == 409, "the cancelled job's image through %s: %d, not 409" % (a.name, status))


def store_down(pg, ds, front, refs):
    """PostgreSQL stopped for ~3 s, then started again."""
    a, b = ds[0], ds[1]
    run_id, _, _ = submit(a, *BIG)
    queued_id, _, _ = submit(b, *JOBS[0])
    deadline = time.time() + 10
    while time.time() < deadline and status_of(b, run_id).get("status") not in ("running",) + ENDED:
        time.sleep(0.05)
    before = {jid: status_of(b, jid).get("status") for jid in (run_id, queued_id)}
    check(any(s in ("queued", "running") for s in before.values()),
          "a job was unfinished when PostgreSQL stopped: %s" % before)
    t_stop = time.time()
    pg.stop()
    print("farm: PostgreSQL stopped in %.2f s; the jobs were %s" % (time.time() - t_stop, before))
    for ep in (a, b):
        status, h, body = ep.call("POST", "/v1/jobs?" + query(JOBS[3][1]), body=scene_bytes(JOBS[3][0]),
                                  headers={"Content-Type": "text/x-rayd-cfg"})
        check(status == 503 and h.get("retry-after", "").strip().isdigit(),
              "POST /v1/jobs to %s with the store down: %d, Retry-After %r %r" %
              (ep.name, status, h.get("retry-after"), body[:200]))
    for ep in (a, b):
        t0, status = time.time(), None
        while time.time() < t0 + 5:
            status = ep.call("GET", "/readyz")[0]
            if status == 503:
                break
            time.sleep(0.1)
        check(status == 503, "GET /readyz on %s with the store down: %s" % (ep.name, status))
    scene, ov = JOBS[1]
    status, h, body = a.call("POST", "/v1/render?" + query(ov), body=scene_bytes(scene),
                             headers={"Content-Type": "text/x-rayd-cfg"}, timeout=60)
    check(status == 200 and h.get("content-type", "").startswith("image/png"),
          "POST /v1/render with the store down: %d %r" % (status, body[:200] if status != 200 else b""))
    if status == 200:
        same_pixels(body, refs[(scene, query(ov))], "the synchronous render with the store down")
    time.sleep(max(0.0, t_stop + 3 - time.time()))
    pg.start()
    t_start = time.time()
    for ep in (a, b):
        status = None
        while time.time() < t_start + 15:
            status = ep.call("GET", "/readyz")[0]
            if status == 200:
                break
            time.sleep(0.1)
        check(status == 200, "GET /readyz on %s 15 s after PostgreSQL came back: %s" % (ep.name, status))
    print("farm: ready again %.2f s after PostgreSQL came back" % (time.time() - t_start))
    scene, ov = JOBS[2]
    new_id, status, _ = submit(front, scene, ov, must=False)
    check(new_id is not None, "POST /v1/jobs through nginx after the store came back: %d" % status)
    by = {run_id: b, queued_id: a}
    if new_id:
        by[new_id] = a
    final = wait_done(by, 40 * SLOW, "the jobs across the store's outage")
    for jid, (scene, ov) in ((run_id, BIG), (queued_id, JOBS[0]), (new_id, JOBS[2])):
        if jid and final[jid].get("status") == "done":
            same_pixels(image(a, jid), refs[(scene, query(ov))], "job %s across the outage" % jid)


def main():
    tmp = tempfile.mkdtemp(prefix="rayd-farm-")
    kept, closers = [tmp], []

    def run():
        t0 = time.time()
        refs = references(tmp)
        print("farm: the CLI's references took %.1f s" % (time.time() - t0))
        pg = stored_jobs.postgresql("rayd-farm-pg-", kept, closers)
        ds = [start_daemon(tmp, i, ["--store", pg.url]) for i in IDS]
        try:
            front_nginx = Nginx(tempfile.mkdtemp(prefix="rayd-farm-nginx-"), [ep.port for ep in ds])
        except (RuntimeError, ValueError) as e:
            raise Abort("nginx did not start: %s" % e)
        kept.append(front_nginx.dir)
        closers.insert(0, front_nginx.stop)
        front = Endpoint("nginx", front_nginx.port, IDS)
        for phase, args in ((through_nginx, (ds, front, refs)), (progressive_across, (ds, refs)),
                            (shared_job, (tmp, ds, refs)), (cancel_across, (ds,)),
                            (store_down, (pg, ds, front, refs))):
            t0 = time.time()
            phase(*args)
            print("farm: %s took %.1f s" % (phase.__name__, time.time() - t0))
        seen.report()
        for ep in ds[:2]:
            rc = ep.daemon.stop()
            check(rc == 0, "%s exited %s after SIGTERM" % (ep.name, rc))
        rc = front_nginx.stop()
        check(rc == 0, "nginx exited %s after SIGTERM" % rc)

    return stored_jobs.bounded_run(check, "farm", BOUND_S, run, STARTED, kept, closers)


if __name__ == "__main__":
    sys.exit(main())
