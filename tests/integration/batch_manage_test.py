"""Managing a class's batches and records over HTTP (docs/grading.md, "A
class over HTTP" and "Records"): GET /v1/grade/batch lists batches newest
first, by assignment, in pages; DELETE /v1/grade/batch/{id} cancels a
running batch (it grades no more, its rows graded before stay, its images
not graded leave the memory budget) and deletes a finished one with its
records and their images; DELETE /v1/grades?student= deletes a student's
records, DELETE /v1/grades/{id} one; every one of these routes answers 404
without --instructor-tokens, 401 without a token and 403 with a wrong one.
On PostgreSQL also: a batch cancelled by another daemon on the store stops
on the daemon grading it, and the routes answer 503 while the store is
down.
On the job store RAYD_TEST_STORE names (tests/support/stored_jobs.py):
sqlite, the default, or postgresql (a server of the test's own).

Run: RAYD=build/rayd python3 tests/integration/batch_manage_test.py"""
import json
import os
import re
import sys
import tempfile
import time
import urllib.parse

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "support"))
from rayd_http import Checks, Daemon, form_parts, metric_value, png, render_png  # noqa: E402
import class_batches  # noqa: E402
import stored_jobs  # noqa: E402

check = Checks("batch manage")
TOKEN = "manage-token-0123456789abcdef"
AUTH = {"Authorization": "Bearer " + TOKEN}
WRONG = {"Authorization": "Bearer not-the-token-0123456789"}
STARTED = []
BOUND_S = int(600 * float(os.environ.get("RAYD_TEST_SLOW", "1")))
NO_BATCH = "no batch with that id (batches expire with their grades, see --grade-ttl)"
RFC3339_MS = re.compile(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z$")


def post_batch(d, parts):
    st, _, b = class_batches.post_batch(d, parts, AUTH)
    check(st == 202, "POST /v1/grade/batch: %d %r" % (st, b[:200]))
    return json.loads(b).get("id", "x") if st == 202 else "x"


def finished(d, parts):
    """A batch of parts, graded to its end: its status."""
    done = class_batches.wait_batch(d, post_batch(d, parts), AUTH)
    check(done.get("status") == "done", "the batch did not end done: %r" % {k: done.get(k) for k in
                                                                            ("status", "total", "done")})
    return done


def answer(d, method, path):
    """(status, JSON body or {}) of an instructor's request."""
    st, _, b = d.request(method, path, headers=AUTH)
    try:
        return st, json.loads(b) if b else {}
    except ValueError:
        return st, {"body": b[:200]}


def message(body):
    return body.get("error", {}).get("message")


ROUTES = (("GET", "/v1/grade/batch"), ("DELETE", "/v1/grade/batch/0123456789abcdef0123456789abcdef"),
          ("DELETE", "/v1/grades?student=ann"), ("DELETE", "/v1/grades/g0123456789abcdef0123456789abcdef"))


def gate(tmp, d):
    """Without --instructor-tokens the routes are not there; with it, a
    token is needed and must be one of the file's."""
    off = os.path.join(tmp, "off")
    os.makedirs(off)
    with Daemon(off) as plain:
        for method, path in ROUTES:
            st, _, _ = plain.request(method, path, headers=AUTH)
            check(st == 404, "without --instructor-tokens %s %s answers %d, not 404" % (method, path, st))
    for method, path in ROUTES:
        st, h, _ = d.request(method, path)
        check(st == 401 and "bearer" in h.get("www-authenticate", "").lower(),
              "%s %s without a token answers %d, not 401 with WWW-Authenticate" % (method, path, st))
        st, _, _ = d.request(method, path, headers=WRONG)
        check(st == 403, "%s %s with a wrong token answers %d, not 403" % (method, path, st))


def listing(d):
    """Newest first, each with its fields; by assignment; limit and the
    next page from the last one's created_at; bad parameters are 400."""
    made = []
    for assignment in ("phong", "diffuse", "phong"):
        made.append(finished(d, [("assignment", None, assignment.encode()), ("image", "ann.png", b"not a png"),
                                 ("image", "ben.png", b"nor this")]))
        time.sleep(0.01)  # apart by a millisecond at least: the order is by time
    ids = [b["id"] for b in reversed(made)]
    st, o = answer(d, "GET", "/v1/grade/batch")
    got = o.get("batches", [])
    check(st == 200 and [b.get("id") for b in got][:3] == ids,
          "GET /v1/grade/batch: %d, not the three newest first: %r" % (st, [b.get("id") for b in got]))
    for b in got[:3]:
        check(sorted(b) == ["assignment", "created_at", "done", "id", "status", "total"] and
              b["status"] == "done" and b["total"] == b["done"] == 2 and RFC3339_MS.match(b["created_at"]),
              "a listed batch: %r" % b)
    st, o = answer(d, "GET", "/v1/grade/batch?assignment=diffuse")
    check(st == 200 and [b["id"] for b in o.get("batches", [])] == [made[1]["id"]],
          "the diffuse batches: %d %r" % (st, o))
    st, o = answer(d, "GET", "/v1/grade/batch?limit=2")
    page = o.get("batches", [])
    check(st == 200 and [b["id"] for b in page] == ids[:2], "limit=2: %d %r" % (st, o))
    if len(page) == 2:
        st, o = answer(d, "GET", "/v1/grade/batch?limit=2&until=" + urllib.parse.quote(page[1]["created_at"]))
        check(st == 200 and [b["id"] for b in o.get("batches", [])] == ids[1:3],
              "the next page from %s: %d %r" % (page[1]["created_at"], st, o))
    for q in ("limit=0", "limit=1001", "limit=ten", "limit=", "until=yesterday", "until=2026-12-01T09:30:00.Z",
              "assignment=%FF"):
        st, o = answer(d, "GET", "/v1/grade/batch?" + q)
        check(st == 400 and o.get("error", {}).get("code") == "parse_error", "?%s answers %d %r" % (q, st, o))
    st, o = answer(d, "GET", "/v1/grade/batch?until=2000-01-01")
    check(st == 200 and o.get("batches") == [], "batches until 2000: %d %r" % (st, o))


def grade_cache_bytes(d):
    _, _, text = d.request("GET", "/metrics")
    return metric_value(text, "rayd_grade_cache_bytes") or 0


BIG = 600


def big_batch(d, right):
    """A batch of BIG images, once it has graded one (on a loaded machine
    the rest take seconds more): its id, and the daemon's
    rayd_grade_cache_bytes then, which holds its images not graded."""
    bid = post_batch(d, [("assignment", None, b"phong")] + [("image", "s%03d.png" % i, right) for i in range(BIG)])
    for _ in range(3000):
        st, now = answer(d, "GET", "/v1/grade/batch/" + bid)
        if now.get("done", 0) >= 1 or now.get("status") != "running":
            break
        time.sleep(0.01)
    return bid, grade_cache_bytes(d)


def cancel_running(d, right):
    """A batch of 600 images, cancelled once it has graded one: the DELETE
    answers cancelled; from then on done does not grow and the rows stay
    those graded before it; the images not graded leave the budget; a
    second DELETE deletes it."""
    n = BIG
    bid, held = big_batch(d, right)
    st, o = answer(d, "DELETE", "/v1/grade/batch/" + bid)
    check(st == 200 and o.get("status") == "cancelled" and o.get("id") == bid and 0 < o.get("done", 0) < n,
          "DELETE of a running batch: %d %r" % (st, {k: o.get(k) for k in ("id", "status", "done", "total")}))
    done = o.get("done", 0)
    freed = held - grade_cache_bytes(d)
    check(freed > (n - done) * len(right) / 2, "cancelling freed %d bytes of the budget; %d images of %d bytes "
          "were not graded" % (freed, n - done, len(right)))
    time.sleep(1.5)
    st, after = answer(d, "GET", "/v1/grade/batch/" + bid)
    rows = after.get("results", [])
    check(st == 200 and after.get("status") == "cancelled" and after.get("done") == done == len(rows),
          "1.5 s after the cancel: %d %r (done %d when cancelled)" %
          (st, {k: after.get(k) for k in ("status", "done", "total")}, done))
    check(rows and all(r.get("pass") is True and not r.get("error") for r in rows),
          "the rows graded before the cancel: %r" % rows[:3])
    st, _ = answer(d, "DELETE", "/v1/grade/batch/" + bid)
    check(st == 204, "DELETE of the cancelled batch answers %d, not 204" % st)
    st, o = answer(d, "GET", "/v1/grade/batch/" + bid)
    check(st == 404 and message(o) == NO_BATCH, "the deleted batch: %d %r" % (st, message(o) or o.get("status")))
    for r in rows[:3]:
        st, _ = answer(d, "GET", "/v1/grades/" + r.get("grade_id", "x"))
        check(st == 404, "a row of the deleted batch answers %d, not 404" % st)
    print("batch manage: cancelled at %d/%d; %.1f MiB of queued images left the budget" % (done, n, freed / 2**20))


def delete_finished(d, right):
    """A finished batch goes with its records and their images (the diff
    from the record and the one kept in memory alike)."""
    done = finished(d, [("assignment", None, b"phong"), ("image", "ann.png", right),
                        ("image", "ben.png", png(320, 240, lambda x, y: (0, 0, 0))), ("image", "cat.png", b"no")])
    rows = done.get("results", [])
    graded = [r for r in rows if not r.get("error")]
    for r in graded:
        st, _, _ = d.request("GET", "/v1/grades/%s/diff.png" % r["grade_id"])
        check(st == 200, "the diff of %s before the delete: %d" % (r["student"], st))
    st, _, b = d.request("DELETE", "/v1/grade/batch/" + done.get("id", "x"), headers=AUTH)
    check(st == 204 and b == b"", "DELETE of a finished batch: %d %r" % (st, b[:200]))
    st, o = answer(d, "GET", "/v1/grade/batch/" + done.get("id", "x"))
    check(st == 404 and message(o) == NO_BATCH, "GET of the deleted batch: %d %r" % (st, message(o) or o.get("status")))
    for r in rows:
        st, _, _ = d.request("GET", "/v1/grades/" + r["grade_id"])
        check(st == 404, "GET /v1/grades/{id} of %s after the delete: %d" % (r["student"], st))
    for r in graded:
        for f in ("diff.png", "image.png"):
            st, _, _ = d.request("GET", "/v1/grades/%s/%s" % (r["grade_id"], f))
            check(st == 404, "%s of %s after the delete: %d" % (f, r["student"], st))
    for bad in (done.get("id", "x"), "0123456789abcdef0123456789abcdef", "a" * 200, "%FF"):
        st, o = answer(d, "DELETE", "/v1/grade/batch/" + bad)
        check(st == 404 and message(o) == NO_BATCH, "DELETE /v1/grade/batch/%s: %d %r" % (bad[:40], st, o))


def grade_one(d, student, image):
    body, ct = form_parts([("assignment", None, b"phong"), ("student", None, student), ("image", "x.png", image)])
    st, _, v = d.request("POST", "/v1/grade", body=body, headers={"Content-Type": ct})
    check(st == 200, "a single grade of %s: %d %r" % (student, st, v[:200]))
    return json.loads(v).get("id", "x") if st == 200 else "x"


def delete_student(d, right):
    """zoe leaves: her records go (two of her own, one in a batch), with
    their images; the batch's others stay; then one record by its id."""
    singles = [grade_one(d, b"zoe", right), grade_one(d, b"zoe", right)]
    done = finished(d, [("assignment", None, b"phong"), ("image", "zoe.png", right), ("image", "yan.png", right)])
    st, o = answer(d, "DELETE", "/v1/grades?student=zoe")
    check(st == 200 and o == {"deleted": 3}, "DELETE /v1/grades?student=zoe: %d %r" % (st, o))
    st, o = answer(d, "GET", "/v1/grades?student=zoe")
    check(st == 200 and o.get("grades") == [], "zoe's records after the delete: %d, %d records" %
          (st, len(o.get("grades", []))))
    for gid in singles:
        for path in ("/v1/grades/" + gid, "/v1/grades/%s/diff.png" % gid):
            st, _, _ = d.request("GET", path)
            check(st == 404, "GET %s after zoe left: %d" % (path, st))
    st, o = answer(d, "GET", "/v1/grade/batch/" + done.get("id", "x"))
    check(st == 200 and [r["student"] for r in o.get("results", [])] == ["yan"] and o.get("done") == 2,
          "the batch after zoe left: %d, done %r, rows of %r" % (st, o.get("done"),
                                                                 [r["student"] for r in o.get("results", [])]))
    st, o = answer(d, "DELETE", "/v1/grades?student=zoe")
    check(st == 200 and o == {"deleted": 0}, "a second DELETE of zoe's records: %d %r" % (st, o))
    for q in ("", "?student=", "?student=%FF", "?student=" + "a" * 300):
        st, o = answer(d, "DELETE", "/v1/grades" + q)
        check(st == 400 and o.get("error", {}).get("code") == "parse_error", "DELETE /v1/grades%s: %d %r" %
              (q[:20], st, o))
    gid = grade_one(d, b"xia", right)
    st, _, b = d.request("DELETE", "/v1/grades/" + gid, headers=AUTH)
    check(st == 204 and b == b"", "DELETE /v1/grades/{id}: %d %r" % (st, b[:200]))
    for path in ("/v1/grades/" + gid, "/v1/grades/%s/diff.png" % gid):
        st, _, _ = d.request("GET", path)
        check(st == 404, "GET %s after its DELETE: %d" % (path, st))
    for bad in (gid, "g0123456789abcdef0123456789abcdef", "nonsense"):
        st, _ = answer(d, "DELETE", "/v1/grades/" + bad)
        check(st == 404, "DELETE /v1/grades/%s: %d, not 404" % (bad, st))
    st, _, _ = d.request("DELETE", "/v1/grades/%s/diff.png" % gid, headers=AUTH)
    check(st == 405, "DELETE of a record's image: %d, not 405" % st)


def other_daemon(tmp, d, flags, right):
    """Two daemons on one PostgreSQL: a DELETE answered by the other one
    cancels the batch, and the daemon grading it stops too: its queued
    images leave its budget and done stays."""
    other_tmp = os.path.join(tmp, "other")
    os.makedirs(other_tmp)
    e = Daemon(other_tmp, flags)
    STARTED.append(e)
    n = BIG
    bid, held = big_batch(d, right)
    st, o = answer(e, "DELETE", "/v1/grade/batch/" + bid)
    check(st == 200 and o.get("status") == "cancelled" and o.get("done", 0) < n,
          "DELETE on the other daemon: %d %r" % (st, {k: o.get(k) for k in ("status", "done", "total")}))
    done, freed = o.get("done", 0), 0
    for _ in range(100):
        freed = held - grade_cache_bytes(d)
        if freed > (n - done) * len(right) / 2:
            break
        time.sleep(0.1)
    check(freed > (n - done) * len(right) / 2, "the grading daemon freed %d bytes of its budget after the other's "
          "cancel; %d images of %d bytes were not graded" % (freed, n - done, len(right)))
    st, after = answer(d, "GET", "/v1/grade/batch/" + bid)
    check(after.get("status") == "cancelled" and after.get("done") == done,
          "after the other daemon's cancel: %r (done %d when cancelled)" %
          ({k: after.get(k) for k in ("status", "done")}, done))
    check(e.stop() == 0, "the other daemon did not exit 0 after SIGTERM")
    print("batch manage: cancelled by the other daemon at %d/%d; the grading daemon freed %.1f MiB" %
          (done, n, freed / 2**20))


def store_down(d, pg):
    """PostgreSQL stopped: every route answers 503 with a message, never a
    500 or a crash; started again, they answer as before."""
    pg.stop()
    try:
        for method, path in ROUTES:
            st, o = answer(d, method, path)
            check(st == 503 and message(o), "%s %s with the store down: %d %r" % (method, path, st, o))
    finally:
        pg.start()
    st, o = answer(d, "GET", "/v1/grade/batch?limit=1")
    check(st == 200, "GET /v1/grade/batch once the store is back: %d %r" % (st, o))


def main():
    tmp = tempfile.mkdtemp(prefix="rayd-batch-manage-")
    kept, closers = [tmp], []

    def run():
        store = stored_jobs.store(tmp, kept, closers)
        tokens = os.path.join(tmp, "tokens")
        with open(tokens, "w") as f:
            f.write("%s\n" % TOKEN)
        right = render_png("scenes/assignments/phong.cfg", os.path.join(tmp, "right.png"))
        flags = store.flags + ["--instructor-tokens", tokens, "--threads", "2", "--max-batch-images", "1000",
                               "--max-batch-bytes", str(200 << 20)]
        d = Daemon(tmp, flags)
        STARTED.append(d)
        print("batch manage: the %s store" % store.engine)
        gate(tmp, d)
        listing(d)
        cancel_running(d, right)
        delete_finished(d, right)
        delete_student(d, right)
        if store.engine == "postgresql":
            other_daemon(tmp, d, flags, right)
            store_down(d, store.pg)
        check(d.stop() == 0, "the daemon did not exit 0 after SIGTERM")

    return stored_jobs.bounded_run(check, "batch manage", BOUND_S, run, STARTED, kept, closers)


if __name__ == "__main__":
    sys.exit(main())
