#!/usr/bin/python3
"""A term over HTTP (docs/grading.md, "A term"), on the store engine
RAYD_TEST_STORE names (sqlite, the default, or postgresql: a server of the
test's own). Three assignments with schedules written relative to now:
`early` due in a week, `late` due 36 hours ago with a three-day window and
a penalty of 0.25 per day, `closed` due two days ago with no window, and
`future`, released tomorrow. Students submit images (right and wrong ones,
some twice) through POST /v1/grade:
- refused 403 `closed` / `not_released` outside the window, nothing recorded;
- each record says its kind, submitted_at, late (late_days 2 for `late`),
  its score of the assignment's points (partial credit from image_credit,
  the late penalty taken off) and whether it counts (latest, or best);
- GET /v1/grades rows (JSON and CSV) carry grade_id, url, kind, counts,
  submitted_at, late, score and points, sorted by student; ?excel=1 starts
  the CSV with the UTF-8 byte order mark;
- the verdict of GET /v1/grades/{id} has its record, counts as of now: a
  later submission takes it over (latest), a better one (best);
- a code grade's record is of kind code and earns, with partial credit,
  its share of configurations right.

Usage: RAYD=build/rayd /usr/bin/python3 tests/integration/term_test.py
Prints `term: N passed, M failed`."""
import csv
import io
import json
import os
import shutil
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
import stored_jobs  # noqa: E402
from rayd_http import TINY_SCENE, Checks, Daemon, form, form_parts, png, render_png  # noqa: E402

check = Checks("term")
TOKEN = "term-token-0123456789abcdef"
AUTH = {"Authorization": "Bearer " + TOKEN}
DAY = 86400


def utc(offset_s):
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(time.time() + offset_s))


def assignments(tmp):
    path = os.path.join(tmp, "assignments")
    os.makedirs(path)
    grades = {
        "early": "points = 10\ncredit = partial\nimage_credit = 0.5:0.4 1:0.1\ndue = %s\n" % utc(7 * DAY),
        "late": "points = 4\ndue = %s\nlate_days = 3\nlate_penalty = 0.25\n" % utc(-36 * 3600),
        "closed": "due = %s\n" % utc(-2 * DAY),
        "future": "release = %s\n" % utc(DAY),
        "best": "points = 10\ncredit = partial\nimage_credit = 0.5:0.4 1:0.1\ncounts = best\n",
    }
    for name, text in grades.items():
        with open(os.path.join(path, name + ".cfg"), "w") as f:
            f.write(TINY_SCENE)
        with open(os.path.join(path, name + ".grade"), "w") as f:
            f.write("title = %s\n%s" % (name, text))
    return path


def grade(d, assignment, student, image):
    body, ctype = form({"assignment": assignment.encode(), "student": student.encode(), "image": image})
    st, _, out = d.request("POST", "/v1/grade", body, {"Content-Type": ctype})
    return st, json.loads(out) if out.startswith(b"{") else {}


def refusals(d, right):
    for name, code in (("closed", "closed"), ("future", "not_released")):
        st, out = grade(d, name, "ann", right)
        check(st == 403 and out.get("error", {}).get("code") == code,
              "%s: %d %s, not 403 %s" % (name, st, out, code))
    st, _, out = d.request("GET", "/v1/grades?student=ann", headers=AUTH)
    check(st == 200 and json.loads(out)["grades"] == [], "a refused submission left a record: %s" % out[:300])


def record_of(d, gid):
    st, _, out = d.request("GET", "/v1/grades/" + gid, headers={"Accept": "application/json"})
    return json.loads(out).get("record", {}) if st == 200 else {}


def submissions(d, right, wrong):
    """ann: early wrong then right; bob: early right then wrong; cat: late
    right; ann: best wrong, right, wrong. The ids by (student, assignment)."""
    ids = {}
    for student, assignment, image in (("ann", "early", wrong), ("bob", "early", right), ("cat", "late", right),
                                       ("ann", "best", wrong), ("ann", "best", right), ("ann", "best", wrong),
                                       ("ann", "early", right), ("bob", "early", wrong)):
        st, out = grade(d, assignment, student, image)
        check(st == 200 and "record" in out, "%s %s: %d %s" % (student, assignment, st, str(out)[:200]))
        ids.setdefault((student, assignment), []).append(out.get("id"))
        rec = out.get("record", {})
        check(rec.get("student") == student and rec.get("kind") == "image" and rec.get("counts") is None,
              "the answer's record: %s" % rec)
        time.sleep(0.01)  # distinct submission times
    return ids


def records(d, ids):
    ann = [record_of(d, g) for g in ids[("ann", "early")]]
    check([r.get("counts") for r in ann] == [False, True], "ann's early: the latest counts: %s" % ann)
    check(ann[1].get("score") == 10 and ann[1].get("points") == 10 and not ann[1].get("late"), "ann: %s" % ann[1])
    # wrong is white: every pixel off, so image_credit's 1:0.1 step
    check(ann[0].get("score") == 1, "a wrong image's partial credit is 0.1 of 10: %s" % ann[0])
    bob = [record_of(d, g) for g in ids[("bob", "early")]]
    check([r.get("counts") for r in bob] == [False, True], "bob's early: the latest counts, worse or not: %s" % bob)
    cat = record_of(d, ids[("cat", "late")][0])
    check(cat.get("late") is True and cat.get("late_days") == 2 and cat.get("score") == 2 and cat.get("points") == 4,
          "cat, 36 h late at 0.25 a day of 4 points: %s" % cat)
    check(cat.get("due_at", "").endswith("Z") and cat.get("submitted_at", "") > cat.get("due_at", ""),
          "cat's times: %s" % cat)
    best = [record_of(d, g) for g in ids[("ann", "best")]]
    check([r.get("counts") for r in best] == [False, True, False], "the best counts: %s" % best)


def code(d):
    """A code grade's record: kind code, partial credit by its share of
    configurations right. Returns its id."""
    with open("tests/codegrade/students/diffuse_missing_max.h", "rb") as f:
        source = f.read()
    body, ctype = form_parts([("assignment", None, b"early"), ("student", None, b"dan"),
                              ("source", "DiffuseMaterial.h", source)])
    st, _, out = d.request("POST", "/v1/grade/code", body, {"Content-Type": ctype})
    o = json.loads(out) if out.startswith(b"{") else {}
    fn, rec = o.get("function", {}), o.get("record", {})
    check(st == 200 and not o.get("pass") and fn.get("failed", 0) > 0, "the code grade: %d %s" % (st, out[:300]))
    share = (fn.get("configurations", 0) - fn.get("failed", 0)) / max(fn.get("configurations", 1), 1)
    check(rec.get("kind") == "code" and abs(rec.get("score", -1) - 10 * share) < 1e-9 and rec.get("points") == 10,
          "code earns its share of 10 points (%.4f): %s" % (10 * share, rec))
    return o.get("id", "")


def listing(d, cid):
    st, _, out = d.request("GET", "/v1/grades", headers=AUTH)
    rows = json.loads(out)["grades"] if st == 200 else []
    check(len(rows) == 9, "9 records, not %d" % len(rows))
    dan = [r for r in rows if r["student"] == "dan"]
    check(len(dan) == 1 and dan[0]["kind"] == "code" and dan[0]["counts"] and dan[0]["grade_id"] == cid,
          "dan's code row: %s" % dan)
    keys = ["student", "assignment", "grade_id", "url", "kind", "counts", "submitted_at", "late", "score", "points"]
    check(all(all(k in r for k in keys) for r in rows), "a row lacks a key: %s" % rows[:1])
    order = [(r["student"], r["assignment"], r["submitted_at"]) for r in rows]
    check(order == sorted(order), "rows are by student, assignment, submission: %s" % order)
    counted = sorted((r["student"], r["assignment"]) for r in rows if r["counts"])
    check(counted == [("ann", "best"), ("ann", "early"), ("bob", "early"), ("cat", "late"), ("dan", "early")],
          "one counting row per student and assignment: %s" % counted)
    check(all(r["url"] == "/v1/grades/" + r["grade_id"] for r in rows), "url is the verdict's address")
    st, h, out = d.request("GET", "/v1/grades", headers=dict(AUTH, Accept="text/csv"))
    check(st == 200 and not out.startswith(b"\xef\xbb\xbf"), "plain CSV has no byte order mark")
    table = list(csv.reader(io.StringIO(out.decode())))
    check(table[0][-1] == "error" and "score" in table[0] and len(table) == 10 and all(len(r) == 17 for r in table),
          "CSV: header and 17 cells a row: %s" % table[:2])
    st, h, bom = d.request("GET", "/v1/grades?excel=1", headers=dict(AUTH, Accept="text/csv"))
    check(st == 200 and bom == b"\xef\xbb\xbf" + out, "?excel=1: the byte order mark, then the same CSV")


def main():
    tmp = tempfile.mkdtemp(prefix="rayd-term-")
    kept, closers = [], []
    try:
        store = stored_jobs.store(tmp, kept, closers)
        tokens = os.path.join(tmp, "tokens")
        with open(tokens, "w") as f:
            f.write(TOKEN + "\n")
        folder = assignments(tmp)
        right = render_png(os.path.join(folder, "early.cfg"), os.path.join(tmp, "right.png"))
        wrong = png(16, 12, lambda x, y: (255, 255, 255))
        flags = store.flags + ["--assignments", folder, "--instructor-tokens", tokens, "--threads", "2"]
        with Daemon(tmp, flags) as d:
            refusals(d, right)
            ids = submissions(d, right, wrong)
            records(d, ids)
            cid = code(d)
            listing(d, cid)
    except stored_jobs.Abort as e:
        check(False, str(e))
    finally:
        for close in closers:
            close()
        if not check.failed:
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            print("term: the logs are in %s" % tmp, file=sys.stderr)
    return check.summary()


if __name__ == "__main__":
    sys.exit(main())
