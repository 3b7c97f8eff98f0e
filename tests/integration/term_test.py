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
  its share of configurations right;
- a whole term on a store of its own: a roster of 30, three assignments,
  late and repeated submissions, a batch with files not on the roster,
  "no submission" rows, both gradebooks held to the importers' rules, and
  a regrade after the scene changed.

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
from class_batches import post_batch, wait_batch  # noqa: E402
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
    if not gid:
        return {}
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
    check(table[0][-1] == "error" and "score" in table[0] and len(table) == 10 and all(len(r) == 19 for r in table),
          "CSV: header and 19 cells a row: %s" % table[:2])
    st, h, bom = d.request("GET", "/v1/grades?excel=1", headers=dict(AUTH, Accept="text/csv"))
    check(st == 200 and bom == b"\xef\xbb\xbf" + out, "?excel=1: the byte order mark, then the same CSV")


# ---- a whole term: a roster of 30, three assignments, the gradebook ----

ROSTER = [("s%02d" % i, "Student %02d" % i, "s%02d@example.org" % i) for i in range(1, 28)] + [
    ("yamada", "山田太郎", "yamada@example.jp"), ("obrien", "O'Brien, Pat", ""), ("eq", "=HYPERLINK(1)", "eq@x")]


def roster_file(tmp):
    path = os.path.join(tmp, "roster.csv")
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\r\n")
        w.writerow(["email", "student", "name"])
        for student, name, email in ROSTER:
            w.writerow([email, student, name])
    return path


def term_assignments(tmp):
    path = os.path.join(tmp, "term")
    os.makedirs(path)
    grades = {
        "a1": "points = 10\ndue = %s\nlate_days = 3\nlate_penalty = 0.1\n" % utc(-30 * 3600),
        "a2": "points = 5\ncredit = partial\nimage_credit = 0.5:0.6 1:0.2\ndue = %s\n" % utc(3 * DAY),
        "a3": "points = 20\ncounts = best\n",
    }
    for name, text in grades.items():
        with open(os.path.join(path, name + ".cfg"), "w") as f:
            f.write(TINY_SCENE)
        with open(os.path.join(path, name + ".grade"), "w") as f:
            f.write(text)
    return path


def graded_batch(d, assignment, images):
    """The batch of images ((student, PNG) pairs), graded to its end; its id."""
    parts = [("assignment", None, assignment.encode())] + [("image", s + ".png", b) for s, b in images]
    st, _, out = post_batch(d, parts, AUTH)
    bid = json.loads(out).get("id", "x") if st == 202 else "x"
    wait_batch(d, bid, AUTH)
    return bid


def term_submissions(d, right, wrong):
    """a1 (late window open, 30 h after due): s01-s20 submit, s01-s05 twice
    (wrong, then right); a2 by the instructor's batch: 28 images, two of
    students not on the roster; a3: s01-s10, best of wrong then right then
    wrong."""
    for i in range(1, 21):
        if i <= 5:
            grade(d, "a1", "s%02d" % i, wrong)
        grade(d, "a1", "s%02d" % i, right if i % 4 else wrong)
    images = [("s%02d" % i, right if i % 3 else wrong) for i in range(1, 27)] + [("ghost", right), ("zed", wrong)]
    bid = graded_batch(d, "a2", images)
    for i in range(1, 11):
        for image in (wrong, right, wrong):
            grade(d, "a3", "s%02d" % i, image)
    return bid


def expected(d):
    """{(student, assignment): score} of the records that count, from the JSON rows."""
    st, _, out = d.request("GET", "/v1/grades", headers=AUTH)
    rows = json.loads(out)["grades"] if st == 200 else []
    return {(r["student"], r["assignment"]): r["score"] for r in rows if r["counts"]}, rows


def check_tables(d, bid, rows):
    a1 = json.loads(d.request("GET", "/v1/grades?assignment=a1", headers=AUTH)[2])["grades"]
    none = sorted(r["student"] for r in a1 if r["error"] == "no submission")
    check(none == sorted(s for s, _, _ in ROSTER if not (s.startswith("s") and 1 <= int(s[1:]) <= 20)),
          "a1: the roster's students without a submission: %s" % none)
    check(all(r["on_roster"] is True for r in a1), "a1: everyone is on the roster")
    check(all(r["graded_at"] is None and r["grade_id"] is None for r in a1 if r["error"] == "no submission"),
          "a no-submission row has no time and no id")
    late = [r for r in a1 if r["grade_id"]]
    check(len(late) == 25 and all(r["late"] for r in late), "a1's 25 records are all late: %d" % len(late))
    st, _, out = d.request("GET", "/v1/grade/batch/%s/results.json" % bid, headers=AUTH)
    b = json.loads(out) if st == 200 else []
    off = sorted(r["student"] for r in b if r["on_roster"] is False)
    check(off == ["ghost", "zed"], "the batch flags the files not on the roster: %s" % off)
    missing = sorted(r["student"] for r in b if r["error"] == "no submission")
    check(missing == ["eq", "obrien", "s27", "yamada"], "the batch's missing students: %s" % missing)
    check(all(not r["late"] for r in b if r["grade_id"]), "a batch's rows are on time")


def moodle_rules(text, points):
    """Moodle's CSV grade import (grade/import/csv): the identifier column
    mapped to ID number must be non-empty in every line with data; a grade
    cell is empty or '-' (no grade) or a number; a new grade item per other
    column, named by its header."""
    table = list(csv.reader(io.StringIO(text)))
    head, body = table[0], [r for r in table[1:] if len(r) > 1]
    problems = []
    if head[:3] != ["ID number", "Email address", "Full name"]:
        problems.append("identity columns %s" % head[:3])
    for r in body:
        if len(r) != len(head) or not r[0].strip():
            problems.append("a line Moodle cannot map: %s" % r)
        for name, v in zip(head[3:], r[3:]):
            if v.strip() not in ("", "-"):
                try:
                    if not 0 <= float(v) <= points[name]:
                        problems.append("%s=%s outside 0..%s" % (name, v, points[name]))
                except ValueError:
                    problems.append("%s=%r is not a number" % (name, v))
    return head, body, problems


def canvas_rules(text, points):
    """Canvas's GradebookImporter: header Student, ID, SIS User ID, SIS
    Login ID, Section, then assignments; a 'Points Possible' line; a
    student found by SIS User ID or SIS Login ID; a cell empty, '-' or a
    number (a decimal comma also read)."""
    table = list(csv.reader(io.StringIO(text)))
    head, problems = table[0], []
    if not ("Student" in head[0] and "ID" in head[1] and head[2] == "SIS User ID" and head[3] == "SIS Login ID"
            and "Section" in head[4]):
        problems.append("header %s" % head[:5])
    pp = [r for r in table[1:] if r and "Points Possible" in r[0]]
    if len(pp) != 1 or [float(v) for v in pp[0][5:]] != [points[a] for a in head[5:]]:
        problems.append("Points Possible line %s" % pp)
    body = [r for r in table[1:] if r and "Points Possible" not in r[0]]
    for r in body:
        if len(r) != len(head) or not (r[2].strip() or r[3].strip()):
            problems.append("a student Canvas cannot find: %s" % r)
        for v in r[5:]:
            if v.strip() not in ("", "-"):
                try:
                    float(v.replace(",", "."))
                except ValueError:
                    problems.append("%r is not a number" % v)
    return head, body, problems


def check_gradebooks(d, scores):
    points = {"a1": 10, "a2": 5, "a3": 20}
    st, h, text = d.request("GET", "/v1/gradebook?format=moodle", headers=AUTH)
    check(st == 200 and h.get("content-type", "").startswith("text/csv"), "moodle: %d" % st)
    head, body, problems = moodle_rules(text.decode(), points)
    check(not problems, "moodle's rules: %s" % problems[:3])
    check(head[3:] == ["a1", "a2", "a3"] and len(body) == 30, "moodle: %s, %d lines" % (head, len(body)))
    roster = {s: (n, e) for s, n, e in ROSTER}
    for r in body:
        student = r[0][1:] if r[0].startswith("'") else r[0]
        check(student in roster and r[1] == roster[student][1], "moodle identity: %s" % r[:3])
        for a, v in zip(head[3:], r[3:]):
            want = scores.get((student, a))
            check((v == "" and want is None) or (want is not None and float(v) == round(want, 2)),
                  "moodle %s %s: %r, the record that counts has %r" % (student, a, v, want))
    guarded = [r for r in body if r[0] == "eq"]
    check(guarded and guarded[0][2] == "'=HYPERLINK(1)", "a formula name is guarded: %s" % guarded)
    st, _, text = d.request("GET", "/v1/gradebook?format=canvas", headers=AUTH)
    head, body, problems = canvas_rules(text.decode(), points)
    check(st == 200 and not problems, "canvas's rules: %d %s" % (st, problems[:3]))
    check(len(body) == 30 and all(r[2] in roster for r in body), "canvas: 30 students by SIS User ID")
    yamada = [r for r in body if r[2] == "yamada"]
    check(yamada and yamada[0][0] == "山田太郎" and yamada[0][3] == "yamada@example.jp", "canvas: %s" % yamada)
    cells = {(r[2], a): v for r in body for a, v in zip(head[5:], r[5:])}
    check(all((v == "") == (scores.get(k) is None) for k, v in cells.items()), "canvas: a cell for each counting record")
    st, _, _ = d.request("GET", "/v1/gradebook?format=excel", headers=AUTH)
    check(st == 400, "an unknown format: %d" % st)
    st, _, _ = d.request("GET", "/v1/gradebook?format=moodle")
    check(st == 401, "the gradebook without a token: %d" % st)


def regrade(d, folder, before):
    """a1's scene changes (its light dims): a regrade grades a1's 25 image
    records again into 25 new records that name them; the old ones stay and
    no longer count; lateness is the original submission's; a second regrade
    takes only the newest line."""
    with open(os.path.join(folder, "a1.cfg"), "w") as f:
        f.write(TINY_SCENE.replace("color = 1 1 1", "color = 0.5 0.5 0.5"))
    st, h, out = d.request("POST", "/v1/grade/regrade?assignment=a1", headers=AUTH)
    b = json.loads(out) if st == 202 else {}
    check(st == 202 and b.get("total") == 25 and h.get("location") == "/v1/grade/batch/" + b.get("id", ""),
          "POST /v1/grade/regrade: %d %s" % (st, out[:200]))
    done = wait_batch(d, b.get("id", "x"), AUTH)
    check(done.get("status") == "done" and done.get("done") == 25, "the regrade ended: %s" % str(done)[:200])
    rows = json.loads(d.request("GET", "/v1/grades?assignment=a1", headers=AUTH)[2])["grades"]
    old = {r["grade_id"]: r for r in before if r["assignment"] == "a1"}
    new = [r for r in rows if r["regrade_of"]]
    check(len(new) == 25 and sorted(r["regrade_of"] for r in new) == sorted(old),
          "each a1 record regraded once: %d" % len(new))
    check(all(r["student"] == old[r["regrade_of"]]["student"] and r["submitted_at"] == old[r["regrade_of"]]["submitted_at"]
              and r["late"] for r in new), "a regrade keeps the student, the submission time and its lateness")
    check(all(not r["pass"] and r["score"] == 0 for r in new), "against the dimmer reference nothing passes")
    kept = [r for r in rows if r["grade_id"] in old]
    check(len(kept) == 25 and not any(r["counts"] for r in kept), "the old verdicts stay, and none counts")
    counted = sorted(r["student"] for r in rows if r["counts"])
    check(counted == sorted("s%02d" % i for i in range(1, 21)), "one regrade counts per student: %s" % counted)
    rec = record_of(d, new[0]["grade_id"] if new else None)
    check(bool(new) and rec.get("regrade_of") == new[0]["regrade_of"], "the verdict's record: %s" % rec)
    st, _, out = d.request("POST", "/v1/grade/regrade?assignment=a1", headers=AUTH)
    again = wait_batch(d, json.loads(out).get("id", "x"), AUTH) if st == 202 else {}
    check(again.get("total") == 25, "a second regrade takes the 25 newest only: %s" % str(again)[:120])
    st, _, _ = d.request("POST", "/v1/grade/regrade?assignment=nope", headers=AUTH)
    check(st == 404, "regrade of no assignment: %d" % st)
    st, _, _ = d.request("POST", "/v1/grade/regrade?assignment=a1")
    check(st == 401, "regrade without a token: %d" % st)


def whole_term(tmp, store_flags, right, wrong):
    folder = term_assignments(tmp)
    flags = store_flags + ["--assignments", folder, "--instructor-tokens", os.path.join(tmp, "tokens"),
                           "--roster", roster_file(tmp), "--threads", "2"]
    with Daemon(tmp, flags) as d:
        t0 = time.time()
        bid = term_submissions(d, right, wrong)
        scores, rows = expected(d)
        check(len(rows) == 25 + 28 + 30, "the term's records: %d" % len(rows))
        check_tables(d, bid, rows)
        check_gradebooks(d, scores)
        regrade(d, folder, rows)
        text = d.request("GET", "/v1/gradebook?format=moodle", headers=AUTH)[2].decode()
        a1 = [r[3] for r in csv.reader(io.StringIO(text))][1:]
        check(sorted(a1) == sorted(["0"] * 20 + [""] * 10), "the gradebook after the regrade: %s" % a1)
        print("term: a whole term (roster 30, 3 assignments, %d records) in %.1f s" % (len(rows), time.time() - t0))


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
        # a term of its own: a store of its own, without the records above
        whole = os.path.join(tmp, "whole")
        os.makedirs(whole)
        shutil.copy(tokens, os.path.join(whole, "tokens"))
        whole_term(whole, stored_jobs.store(whole, kept, closers).flags, right, wrong)
    except (stored_jobs.Abort, RuntimeError) as e:
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
