#!/usr/bin/env python3
"""The job store's faults answered for what they are (docs/operations.md,
"The job store's faults"), on the SQLite store:

- A full disk: the daemon's --data-dir on a 16 MiB tmpfs, filled but for
  32 KiB. Once /readyz answers 503 with the reason `store_full`, POST
  /v1/jobs answers 507 `store_full` with a message saying so, every time,
  though a job's small write might still fit; once the filler is deleted, jobs are taken
  again and /readyz is 200. The tmpfs is mounted in a mount namespace of
  the daemon's own (`unshare --mount`, with `--map-root-user` when not
  root), seen from here through /proc/PID/root.
- A damaged page: a store whose pages are overwritten with garbage does not
  start: exit 3 with a message saying the store is damaged (the bounded
  PRAGMA quick_check at start).
- A zero-length rayd.sqlite3 does not start as an empty store: exit 3,
  saying the file is empty.
- GET /v1/grade/batch/{id} of no batch: 404 "no batch with that id".

Usage: RAYD=build/rayd /usr/bin/python3 tests/integration/store_faults_test.py
It prints `store faults: N passed, M failed` and exits 1 on any failure."""
import json
import os
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from rayd_http import RAYD, Checks, Daemon  # noqa: E402

check = Checks("store faults")
TOKEN = "faults-token-0123456789abcdef"
SCENE = open("scenes/phong.cfg", "rb").read()


def post_job(d):
    return d.request("POST", "/v1/jobs?width=64&height=48", body=SCENE, headers={"Content-Type": "text/x-rayd-cfg"})


def ready(d):
    st, _, b = d.request("GET", "/readyz")
    return st, (json.loads(b).get("reasons") or [None])[0] if st != 200 else None


def until(what, bound=20):
    t0 = time.time()
    while time.time() - t0 < bound:
        r = what()
        if r:
            return r
        time.sleep(0.1)
    return what()


def run_full_disk(tmp):
    mnt = os.path.join(tmp, "small")
    os.mkdir(mnt)
    root = [] if os.geteuid() == 0 else ["--map-root-user"]
    port_file = os.path.join(tmp, "port")
    log = open(os.path.join(tmp, "full.log"), "wb")
    script = "mount -t tmpfs -o size=16m tmpfs \"$0\" && exec \"$@\""
    cmd = (["unshare", "--mount", "--propagation", "private"] + root +
           ["sh", "-c", script, mnt, os.path.abspath(RAYD), "serve", "--listen", "127.0.0.1:0", "--port-file",
            port_file, "--data-dir", os.path.join(mnt, "data"), "--threads", "1"])
    proc = subprocess.Popen(cmd, stdout=log, stderr=log, stdin=subprocess.DEVNULL)
    try:
        port = until(lambda: os.path.exists(port_file) and open(port_file).read().strip(), 20)
        check(bool(port), "the daemon on a tmpfs did not start: %s" % open(os.path.join(tmp, "full.log")).read()[-500:])
        if not port:
            return
        d = Daemon.__new__(Daemon)
        d.host, d.port, d.proc = "127.0.0.1", int(port), proc
        st, _, b = post_job(d)
        check(st == 202, "a job before the disk is full: %d %r" % (st, b[:200]))
        check(ready(d) == (200, None), "ready before the disk is full: %r" % (ready(d),))
        # The daemon's view of the tmpfs, through its root.
        fill = os.path.join("/proc/%d/root" % proc.pid, mnt.lstrip("/"), "filler")
        # Unbuffered: a buffered file keeps what the last write could not
        # put, and its close raises ENOSPC writing it again, whenever the
        # room left is not a whole number of writes (how much the daemon
        # wrote before decides that).
        with open(fill, "wb", buffering=0) as f:
            try:
                while True:
                    f.write(b"\0" * 65536)
                    f.flush()
            except OSError:
                pass
        # 32 KiB left: a job's small write may fit where the probe's 64 KiB
        # does not (as SQLite's reused log pages may let it), so jobs may
        # be taken until some write finds no space; from then on the daemon
        # takes none, as /readyz says.
        os.truncate(fill, os.path.getsize(fill) - 32768)
        taken = 0
        r = ready(d)
        while r != (503, "store_full") and taken < 200:
            taken += post_job(d)[0] == 202
            time.sleep(0.05)
            r = ready(d)
        check(r == (503, "store_full"), "/readyz on a full disk: %r" % (r,))
        answers = [post_job(d) for _ in range(3)]
        st, _, b = answers[0]
        body = json.loads(b) if b else {}
        check(st == 507 and body.get("error", {}).get("code") == "store_full" and
              b"no space left" in b, "POST /v1/jobs once /readyz says the store is full: %d %r" % (st, b[:300]))
        check([a[0] for a in answers] == [507] * 3, "POSTs on a full disk: %r" % ([a[0] for a in answers],))
        print("store faults: full disk: %d job(s) taken, then POST /v1/jobs %d %s; /readyz %r" %
              (taken, st, b[:300].decode(), r))
        os.unlink(fill)
        st, _, b = until(lambda: (lambda a: a if a[0] == 202 else None)(post_job(d)), 40) or post_job(d)
        check(st == 202, "a job once space is freed: %d %r" % (st, b[:200]))
        r = until(lambda: ready(d) == (200, None), 40)
        check(r, "ready again once space is freed: %r" % (ready(d),))
    finally:
        proc.terminate()
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        log.close()


def start_fails(tmp, data, what):
    """rayd serve on data that must not start: its exit status and stderr."""
    try:
        p = subprocess.run([RAYD, "serve", "--listen", "127.0.0.1:0", "--data-dir", data], capture_output=True,
                           timeout=15, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired as e:
        err = (e.stderr or b"").decode("utf-8", "replace")
        print("store faults: %s: it started and served: %s" % (what, err.strip().splitlines()[0] if err.strip() else ""))
        return None, err
    err = p.stderr.decode("utf-8", "replace")
    print("store faults: %s: exit %d: %s" % (what, p.returncode, err.strip().splitlines()[-1] if err.strip() else ""))
    return p.returncode, err


def damaged_store(tmp):
    data = os.path.join(tmp, "damaged")
    with Daemon(tmp, ["--data-dir", data]) as d:
        for _ in range(30):
            post_job(d)
    path = os.path.join(data, "rayd.sqlite3")
    db = sqlite3.connect(path)
    db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    page = db.execute("PRAGMA page_size").fetchone()[0]
    # The last three pages that hold rows or index entries (dbstat counts
    # page 1 as the first), not the schema's: a store that opens, and that
    # only a reader of those rows would find damaged. Not simply the file's
    # last pages: those may be free (deleted rows), which no check reads.
    used = [r[0] for r in db.execute("SELECT pageno FROM dbstat WHERE name != 'sqlite_schema' "
                                     "AND pagetype IN ('leaf', 'internal') ORDER BY pageno DESC LIMIT 3")]
    db.close()
    check(len(used) == 3, "the store has only %d pages in use" % len(used))
    with open(path, "r+b") as f:
        for p in used:
            f.seek((p - 1) * page)
            f.write(bytes((i * 37 + p) & 0xff for i in range(page)))
    rc, err = start_fails(tmp, data, "a damaged page")
    check(rc == 3 and "damaged" in err, "a damaged store starts with exit %s: %s" % (rc, err[-400:]))


def empty_file(tmp):
    data = os.path.join(tmp, "empty")
    os.mkdir(data)
    open(os.path.join(data, "rayd.sqlite3"), "wb").close()
    rc, err = start_fails(tmp, data, "a zero-length rayd.sqlite3")
    check(rc == 3 and "empty" in err, "a zero-length rayd.sqlite3 starts with exit %s: %s" % (rc, err[-400:]))
    check(os.path.getsize(os.path.join(data, "rayd.sqlite3")) == 0, "the empty file was written to")


def unknown_batch(tmp):
    tokens = os.path.join(tmp, "tokens")
    with open(tokens, "w") as f:
        f.write(TOKEN + "\n")
    with Daemon(tmp, ["--data-dir", os.path.join(tmp, "batches"), "--instructor-tokens", tokens]) as d:
        for bid in ("0123456789abcdef", "x", "0123456789abcdef0123456789abcdef"):
            st, _, b = d.request("GET", "/v1/grade/batch/" + bid, headers={"Authorization": "Bearer " + TOKEN})
            check(st == 404 and b"no batch with that id" in b, "GET /v1/grade/batch/%s: %d %r" % (bid, st, b[:200]))


def main():
    tmp = tempfile.mkdtemp(prefix="rayd-store-faults-")
    try:
        run_full_disk(tmp)
        damaged_store(tmp)
        empty_file(tmp)
        unknown_batch(tmp)
    finally:
        if not check.failed:
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            print("store faults: the logs are in %s" % tmp, file=sys.stderr)
    return check.summary()


if __name__ == "__main__":
    sys.exit(main())
