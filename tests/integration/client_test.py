#!/usr/bin/env python3
"""clients/python/rayd_client.py against a real daemon: every function of
the client, on a daemon with --instructor-tokens and a tiny assignment.

  - render: the PNG of the size asked, byte for byte `rayd render`'s with
    the same overrides; the X-Rayd-* figures and the job behind it; the EXR
    when asked; a scene's syntax error as RaydError 400 with line and column;
    an override the document does not have refused before sending;
  - submit, job, wait, image: a stored job done, its PNG `rayd render`'s;
    cancel: a runaway job ends cancelled; an unknown job is RaydError 404;
  - grade: `rayd render`'s image of the assignment passes and a wrong one
    fails, by assignment and by scene; grade_record gives the same verdict;
    grade_file its heat map;
  - grade_code: a correct diffuse header passes, a broken one is RaydError
    422 compile_error; skeleton and lobe;
  - grade_batch, batch, wait_batch, batch_table, grades, grades_csv: two
    students, one graded and one error row; without the token RaydError 401,
    with a wrong one 403; batches lists it, delete_student and delete_grade
    delete records, delete_batch the finished batch;
  - assignments, assignment_scene, scenes, scene, health, ready.

Usage: RAYD=build/rayd /usr/bin/python3 tests/integration/client_test.py
(from the repository root). The daemon listens on 127.0.0.1 on a port it
picks (--port-file) and is stopped by its pid.
"""
import json
import os
import shutil
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "support"))
sys.path.insert(0, os.path.join(HERE, "..", "..", "clients", "python"))
from rayd_http import RUNAWAY_SCENE, TINY_SCENE, Checks, Daemon, cli_render, decode_png, png, tiny_assignments
from rayd_client import Batch, BatchSummary, Client, CodeGrade, GradeRow, Job, RaydError, Render, Verdict

check = Checks("client")
TOKEN = "client-test-instructor-token-01"
SCENE, RUNAWAY = TINY_SCENE, RUNAWAY_SCENE


def raises(fn, status, code=None):
    """The RaydError fn() raises (checked to have status and code), or None."""
    try:
        fn()
    except RaydError as e:
        check(e.status == status and (code is None or e.code == code),
              "expected %d %s, got %d %s: %s" % (status, code, e.status, e.code, e.message))
        return e
    check(False, "expected RaydError %d %s, got an answer" % (status, code))
    return None


def renders(c, tmp, scene_path):
    r = c.render(SCENE, width=8, height=6, samples=2, seed=3)
    check(isinstance(r, Render) and r.content_type == "image/png", "render: %r" % getattr(r, "content_type", r))
    w, h, _ = decode_png(r.image)
    check((w, h) == (8, 6), "render: a %dx%d PNG for width=8 height=6" % (w, h))
    cli = cli_render(scene_path, os.path.join(tmp, "cli.png"), {"width": 8, "height": 6, "samples": 2, "seed": 3})
    check(r.image == cli, "render: not rayd render's bytes")
    check(r.samples == 2 and r.passes is not None and r.render_ms is not None and r.render_ms >= 0,
          "render: the X-Rayd-* figures: samples=%s passes=%s ms=%s" % (r.samples, r.passes, r.render_ms))
    check(r.job_id and len(r.job_id) == 32, "render: X-Rayd-Job %r" % r.job_id)
    j = c.job(r.job_id)
    check(isinstance(j, Job) and j.status == "done" and j.width == 8 and j.samples == 2,
          "render: its job %s" % dict(j))
    with open("scenes/phong.json") as f:
        rj = c.render(f.read(), width=8, height=6)
    check(decode_png(rj.image)[:2] == (8, 6), "render of a JSON scene")
    exr = c.render(SCENE, exr=True, width=4, height=3)
    check(exr.content_type == "image/x-exr" and exr.image[:4] == b"\x76\x2f\x31\x01", "render exr=True: %s %r" %
          (exr.content_type, exr.image[:4]))
    e = raises(lambda: c.render("[render]\nwidth = 64O\n"), 400, "parse_error")
    check(e is not None and e.line == 2, "a syntax error's line: %s" % (e and e.line))
    raises(lambda: c.render(SCENE, width=0), 400, "parse_error")
    try:
        c.render(SCENE, quality=3)
        check(False, "render took an override the document does not have")
    except ValueError:
        check(True, "render(quality=...) refused")


def jobs(c, tmp, scene_path):
    j = c.submit(SCENE, width=8, height=6, hdr=True)
    check(isinstance(j, Job) and len(j.id or "") == 32 and j.status in ("queued", "running", "done"),
          "submit: %s" % dict(j))
    done = c.wait(j.id, timeout=60)
    check(done.status == "done" and done.progress == 1 and isinstance(done.curve, list) and done.curve,
          "wait: %s" % dict(done))
    img = c.image(j.id)
    check(img == cli_render(scene_path, os.path.join(tmp, "job.png"), {"width": 8, "height": 6}),
          "image: not rayd render's bytes")
    check(c.image(j.id, exr=True)[:4] == b"\x76\x2f\x31\x01", "image exr=True of a job submitted with hdr")
    check(decode_png(c.image(j.id, partial=True))[:2] == (8, 6), "image partial=True")
    slow = c.submit(RUNAWAY)
    gone = c.cancel(slow.id)
    check(isinstance(gone, Job) and gone.id == slow.id, "cancel: %s" % dict(gone))
    check(c.wait(slow.id, timeout=30).status == "cancelled", "a cancelled job ends cancelled")
    raises(lambda: c.image(slow.id), 409)
    raises(lambda: c.job("0" * 32), 404, "not_found")


def grades(c, tmp):
    ref = cli_render(os.path.join(tmp, "assignments", "tiny.cfg"), os.path.join(tmp, "tiny.png"))
    wrong = png(16, 12, lambda x, y: (255, 0, 255))
    v = c.grade(ref, assignment="tiny", student="ann")
    check(isinstance(v, Verdict) and v.pass_ is True and v.assignment == "tiny" and v.metrics["max_abs"] == 0,
          "grade: the reference's own image: %s" % dict(v))
    bad = c.grade(wrong, scene=SCENE)
    check(bad.pass_ is False and bad.assignment is None and bad.metrics["failed_pixels"] > 0,
          "grade: a magenta image by scene: %s" % dict(bad))
    again = c.grade_record(v.id)
    check(isinstance(again, Verdict) and again.id == v.id and again.pass_ is True and again.metrics == v.metrics,
          "grade_record: %s" % dict(again))
    check(decode_png(c.grade_file(bad.id, "diff.png"))[:2] == (16, 12), "grade_file diff.png")
    raises(lambda: c.grade(ref, assignment="nosuch"), 404)
    raises(lambda: c.grade(b"not a png", assignment="tiny"), 415)
    raises(lambda: c.grade_record("g" + "0" * 32), 404)
    return v


def code(c):
    with open("tests/codegrade/students/diffuse_ok.h", "rb") as f:
        right = f.read()
    g = c.grade_code(right, "tiny", filename="DiffuseMaterial.h", student="ann")
    check(isinstance(g, CodeGrade) and g.pass_ is True and g.assignment == "tiny" and g.id,
          "grade_code: diffuse_ok: %s" % str(dict(g))[:300])
    svg = c.lobe(g.id)
    check("<svg" in svg[:400], "lobe: %r" % svg[:80])
    e = raises(lambda: c.grade_code(b"int x = ;\n", "tiny", filename="DiffuseMaterial.h"), 422, "compile_error")
    if e is not None:
        body = CodeGrade(json.loads(e.body))
        check(body.pass_ is False and body.compile, "a compile error's body: %s" % str(dict(body))[:300])
    sk = c.skeleton("phong")
    check("calcReflectedLight" in sk, "skeleton phong: %r" % sk[:80])
    raises(lambda: c.skeleton("mirror"), 404)


def klass(base, tmp):
    teacher = Client(base, token=TOKEN, timeout=60)
    ref = cli_render(os.path.join(tmp, "assignments", "tiny.cfg"), os.path.join(tmp, "tiny.png"))
    b = teacher.grade_batch("tiny", images={"bea": ref, "ben": b"nope"})
    # The 202 is the batch as it stands: running, or already done when the
    # reference was cached and the images graded before the answer left.
    check(isinstance(b, Batch) and b.status in ("running", "done") and b.total == 2, "grade_batch: %s" % dict(b))
    done = teacher.wait_batch(b.id, timeout=60)
    rows = {r.student: r for r in done.results}
    check(done.status == "done" and set(rows) == {"bea", "ben"}, "wait_batch: %s" % dict(done))
    check(rows.get("bea") is not None and isinstance(rows["bea"], GradeRow) and rows["bea"].pass_ is True,
          "bea's row: %s" % rows.get("bea"))
    check(rows.get("ben") is not None and rows["ben"].pass_ is False and rows["ben"].error,
          "ben's row is an error: %s" % rows.get("ben"))
    check(teacher.batch(b.id).done == 2, "batch: done")
    table = teacher.batch_table(b.id, "json")
    check(sorted(r.student for r in table) == ["bea", "ben"], "batch_table json: %s" % table)
    csv = teacher.batch_table(b.id, "csv")
    check(csv.startswith("student,assignment,pass,") and "bea" in csv, "batch_table csv: %r" % csv[:120])
    listed = teacher.grades(assignment="tiny")
    check(all(isinstance(r, GradeRow) for r in listed) and {"ann", "bea", "ben"} <= {r.student for r in listed},
          "grades(assignment=tiny): %s" % [r.student for r in listed])
    check([r.student for r in teacher.grades(student="bea")] == ["bea"], "grades(student=bea)")
    check(teacher.grades_csv(student="bea").count("\n") == 2, "grades_csv(student=bea)")
    raises(lambda: teacher.grades(since="soon"), 400, "parse_error")
    e = raises(lambda: Client(base).grades(), 401, "unauthorized")
    check(e is not None and e.headers.get("WWW-Authenticate", "").startswith("Bearer"), "401's WWW-Authenticate")
    raises(lambda: Client(base, token="wrong-wrong-wrong-1").batch(b.id), 403, "forbidden")
    raises(lambda: Client(base).grade_batch("tiny", images={"x": ref}), 401, "unauthorized")
    manage(base, teacher, b.id, ref)


def manage(base, teacher, bid, ref):
    """batches lists the batch; delete_student, delete_grade and
    delete_batch of the finished batch (None: deleted); 401 without the
    token."""
    listed = teacher.batches(assignment="tiny", limit=5)
    check(listed and isinstance(listed[0], BatchSummary) and listed[0].id == bid and listed[0].created_at,
          "batches(assignment=tiny): %s" % listed)
    raises(lambda: teacher.batches(limit=0), 400, "parse_error")
    v = teacher.grade(ref, assignment="tiny", student="cid")
    check(teacher.delete_student("cid") == 1, "delete_student(cid)")
    raises(lambda: teacher.grade_record(v.id), 404, "not_found")
    v = teacher.grade(ref, assignment="tiny", student="dee")
    check(teacher.delete_grade(v.id) is None, "delete_grade")
    raises(lambda: teacher.delete_grade(v.id), 404, "not_found")
    check(teacher.delete_batch(bid) is None, "delete_batch of a finished batch")
    raises(lambda: teacher.batch(bid), 404, "not_found")
    raises(lambda: Client(base).delete_student("bea"), 401, "unauthorized")


def listings(c):
    names = [a.get("name") for a in c.assignments().get("assignments", [])]
    check("tiny" in names, "assignments: %s" % names)
    check(c.assignment_scene("tiny") == SCENE, "assignment_scene: not the file")
    scenes = [s.get("name") for s in c.scenes().get("scenes", [])]
    check("phong.cfg" in scenes and "phong.json" in scenes, "scenes: %s" % scenes[:10])
    with open("scenes/phong.cfg") as f:
        check(c.scene("phong.cfg") == f.read(), "scene phong.cfg: not the file")
    raises(lambda: c.scene("nosuch"), 404)
    check(c.health() == {"status": "ok"}, "health")
    check(c.ready().get("status") == "ready", "ready")


def main():
    tmp = tempfile.mkdtemp(prefix="rayd-client-")
    tokens = os.path.join(tmp, "tokens")
    with open(tokens, "w") as f:
        f.write(TOKEN + "\n")
    scene_path = os.path.join(tmp, "small.cfg")
    with open(scene_path, "w") as f:
        f.write(SCENE)
    d = Daemon(tmp, ["--threads", "2", "--assignments", tiny_assignments(tmp), "--instructor-tokens", tokens,
                     "--scenes", "scenes", "--job-timeout-ms", "20000"])
    try:
        base = "http://127.0.0.1:%d" % d.port
        c = Client(base, timeout=60)
        listings(c)
        renders(c, tmp, scene_path)
        jobs(c, tmp, scene_path)
        grades(c, tmp)
        code(c)
        klass(base, tmp)
    finally:
        check(d.stop() == 0, "the daemon did not exit 0 after SIGTERM")
    if not check.failed:
        shutil.rmtree(tmp, ignore_errors=True)
    return check.summary()


if __name__ == "__main__":
    sys.exit(main())
