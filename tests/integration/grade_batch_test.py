"""Grading a class over HTTP (docs/http-api.md, "Grading a class"): the
instructors' token gate, batches of image parts and of archives (zip and
tar.gz) with their limits, the rows, the CSV and JSON exports, the records'
listing, and the records after a restart; then the time a batch of 100
320x240 images takes.

Run: RAYD=build/rayd python3 tests/integration/grade_batch_test.py"""
import csv
import io
import json
import os
import shutil
import sys
import tarfile
import tempfile
import threading
import time
import zipfile

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "support"))
from rayd_http import RAYD, Checks, Daemon, decode_png, form_parts, png  # noqa: E402
import class_batches  # noqa: E402

import subprocess  # noqa: E402

check = Checks("grade batch")
TOKEN = "class-token-0123456789abcdef"
AUTH = {"Authorization": "Bearer " + TOKEN}
COLUMNS = ["student", "assignment", "pass", "failed_fraction", "max_abs", "psnr_db", "ssim", "graded_at", "grade_id",
           "url", "kind", "counts", "submitted_at", "late", "score", "points", "on_roster", "regrade_of", "error"]


def render(scene_text, out):
    path = out + ".cfg"
    with open(path, "w") as f:
        f.write(scene_text)
    subprocess.run([RAYD, "render", path, "-o", out, "--quiet"], check=True, capture_output=True, timeout=300)
    with open(out, "rb") as f:
        return f.read()


def class_images(tmp):
    """Five students: one right, one with a wrong shininess, one black, one
    of the wrong size, one that is not a PNG. {student: (bytes, expected)}
    with expected "pass", "fail" or "error"."""
    scene = open("scenes/assignments/phong.cfg").read()
    right = render(scene, os.path.join(tmp, "right.png"))
    wrong = render(scene.replace("shininess = 10", "shininess = 80"), os.path.join(tmp, "wrong.png"))
    return {
        "alice": (right, "pass"),
        "bob": (wrong, "fail"),
        "carol": (png(320, 240, lambda x, y: (0, 0, 0)), "fail"),
        "dave": (png(32, 24, lambda x, y: (9, 9, 9)), "error"),
        "erin": (b"not a png at all", "error"),
    }


def post_batch(d, parts, headers=AUTH):
    return class_batches.post_batch(d, parts, headers)


def wait_batch(d, bid, bound=120):
    return class_batches.wait_batch(d, bid, AUTH, bound)


def verdicts_right(rows, images, what):
    by = {r["student"]: r for r in rows}
    check(sorted(by) == sorted(images), "%s: rows of %s, students %s" % (what, sorted(by), sorted(images)))
    for student, (_, want) in images.items():
        r = by.get(student, {})
        got = "error" if r.get("error") else ("pass" if r.get("pass") else "fail")
        check(got == want, "%s: %s %s, expected %s (%r)" % (what, student, got, want, r))
        if want != "error":
            check(isinstance(r.get("psnr_db"), (int, float)) and isinstance(r.get("ssim"), (int, float)),
                  "%s: %s has no metrics: %r" % (what, student, r))
        else:
            check(r.get("psnr_db") is None and r.get("pass") is False, "%s: %s's error row: %r" % (what, student, r))
    return by


def gate(tmp):
    bad = os.path.join(tmp, "bad-tokens")
    with open(bad, "w") as f:
        f.write("# instructors\nshort\n")
    p = subprocess.run([RAYD, "serve", "--listen", "127.0.0.1:0", "--data-dir", os.path.join(tmp, "bad"),
                        "--instructor-tokens", bad], capture_output=True, timeout=30)
    check(p.returncode == 3 and b"bad-tokens:2:" in p.stderr,
          "a token file with a short token: exit %d, %r" % (p.returncode, p.stderr[-200:]))
    os.makedirs(os.path.join(tmp, "off"))
    with Daemon(os.path.join(tmp, "off")) as d:
        for method, path in (("POST", "/v1/grade/batch"), ("GET", "/v1/grades"), ("GET", "/v1/grade/batch/x")):
            st, _, b = d.request(method, path, headers=AUTH)
            check(st == 404, "without --instructor-tokens %s %s answers %d, not 404" % (method, path, st))


def image_batch(d, images):
    st, _, _ = post_batch(d, [("assignment", None, b"phong")], headers={})
    check(st == 401, "a batch without a token answers %d, not 401" % st)
    st, h, _ = post_batch(d, [("assignment", None, b"phong")], headers={"Authorization": "Bearer wrong-token"})
    check(st == 403, "a batch with a wrong token answers %d, not 403" % st)
    parts = [("assignment", None, b"phong")] + [("image", s + ".png", b) for s, (b, _) in images.items()]
    st, h, b = post_batch(d, parts)
    o = json.loads(b) if st == 202 else {}
    check(st == 202 and o.get("total") == 5 and o.get("status") == "running",
          "POST /v1/grade/batch: %d %r" % (st, b[:300]))
    check(h.get("location") == "/v1/grade/batch/%s" % o.get("id"), "the 202's Location: %r" % h.get("location"))
    done = wait_batch(d, o.get("id", "x"))
    check(done.get("status") == "done" and done.get("done") == 5, "the batch did not end done: %r" % done)
    by = verdicts_right(done.get("results", []), images, "image parts")
    st, h, text = d.request("GET", "/v1/grade/batch/%s/results.csv" % o.get("id"), headers=AUTH)
    rows = list(csv.reader(io.StringIO(text.decode())))
    check(st == 200 and h.get("content-type", "").startswith("text/csv") and rows and rows[0] == COLUMNS,
          "results.csv: %d %r" % (st, rows[:1]))
    csv_by = {r[0]: r for r in rows[1:]}
    for s, r in by.items():
        c = csv_by.get(s, [])
        check(len(c) == len(COLUMNS) and c[2] == ("true" if r["pass"] else "false") and c[1] == "phong",
              "results.csv's row of %s: %r (JSON %r)" % (s, c, r))
    st, _, rj = d.request("GET", "/v1/grade/batch/%s/results.json" % o.get("id"), headers=AUTH)
    check(st == 200 and json.loads(rj) == done.get("results"), "results.json is not the batch's rows")
    for s, r in by.items():
        st, _, v = d.request("GET", "/v1/grades/" + r["grade_id"])
        verdict = json.loads(v) if st == 200 else {}
        check(st == 200 and verdict.get("pass") == r["pass"], "GET /v1/grades/%s (%s): %d %r" %
              (r["grade_id"], s, st, v[:200]))
        if not r.get("error"):
            st, h, diff = d.request("GET", "/v1/grades/%s/diff.png" % r["grade_id"])
            check(st == 200 and decode_png(diff)[:2] == (320, 240), "the diff of %s: %d" % (s, st))
    return o.get("id"), by


def archive_batches(d, images):
    z = io.BytesIO()
    with zipfile.ZipFile(z, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("class/", b"")
        for s, (b, _) in images.items():
            zf.writestr("class/%s.png" % s, b)
        zf.writestr("__MACOSX/class/._alice.png", b"junk")
    t = io.BytesIO()
    with tarfile.open(fileobj=t, mode="w:gz") as tf:
        for s, (b, _) in images.items():
            info = tarfile.TarInfo("week3/%s.png" % s)
            info.size = len(b)
            tf.addfile(info, io.BytesIO(b))
    for kind, data in (("zip", z.getvalue()), ("tar.gz", t.getvalue())):
        st, _, b = post_batch(d, [("assignment", None, b"phong"), ("archive", "class." + kind, data)])
        o = json.loads(b) if st == 202 else {}
        check(st == 202 and o.get("total") == 5, "a %s batch: %d %r" % (kind, st, b[:300]))
        done = wait_batch(d, o.get("id", "x"))
        verdicts_right(done.get("results", []), images, "a %s archive" % kind)


NAMES = ["m\u00fcller", "bob", "Jos\u00e9", "\u674e\u96f7", "zo\u00eb"]


def utf8_names(d, images):
    """Names that are not ASCII, as zip tools flag them (bit 11, Python's
    zipfile): every student graded under the UTF-8 name."""
    right = images["alice"][0]
    z = io.BytesIO()
    with zipfile.ZipFile(z, "w") as zf:
        for n in NAMES:
            zf.writestr(n + ".png", right)
    flags = [i.flag_bits & 0x800 for i in zipfile.ZipFile(io.BytesIO(z.getvalue())).infolist()]
    check(flags.count(0x800) == 4, "the zip's names are not flagged UTF-8: %r" % flags)
    st, _, b = post_batch(d, [("assignment", None, b"phong"), ("archive", "class.zip", z.getvalue())])
    o = json.loads(b) if st == 202 else {}
    check(st == 202 and o.get("total") == 5, "the zip of %s: %d %r" % (NAMES, st, b[:300]))
    done = wait_batch(d, o.get("id", "x"))
    rows = {r["student"]: r for r in done.get("results", [])}
    check(done.get("status") == "done" and sorted(rows) == sorted(NAMES) and all(r["pass"] for r in rows.values()),
          "the zip of %s: %r" % (NAMES, {k: done.get(k) for k in ("status", "total", "done", "results")}))


def hostile_archives(d):
    """tests/hostile's archives: the names of a zip flagged UTF-8 are every
    row (not PNGs: error rows, under those names), a tar's Latin-1 name is
    an error row saying it is not UTF-8."""
    for path, want in (("batch_utf8_names.zip", {n: "not a PNG" for n in NAMES}),
                       ("batch_latin1_names.tar", {"m%FCller": "is not UTF-8", "bob": "not a PNG"})):
        with open(os.path.join("tests", "hostile", path), "rb") as f:
            data = f.read()
        st, _, b = post_batch(d, [("assignment", None, b"phong"), ("archive", path, data)])
        check(st == 202, "tests/hostile/%s: %d %r" % (path, st, b[:200]))
        rows = ends(d, json.loads(b).get("id", "x") if st == 202 else "x", path)
        check(sorted(rows) == sorted(want) and all(w in (rows[n].get("error") or "") for n, w in want.items()),
              "tests/hostile/%s: rows %r" % (path, {n: r.get("error") for n, r in rows.items()}))


def ends(d, bid, what):
    """The batch ends, every student with a row: its rows by student."""
    done = wait_batch(d, bid, 30)
    rows = {r["student"]: r for r in done.get("results", [])}
    check(done.get("status") == "done" and done.get("done") == done.get("total") == len(rows),
          "%s: %r" % (what, {k: done.get(k) for k in ("status", "total", "done")}))
    return rows


def names_not_utf8(d, images):
    """Names that are not UTF-8 are error rows that say so, shown with
    their bad bytes as %HH; a name cut at the 255-byte bound is cut at a
    character; the batch always ends."""
    right = images["alice"][0]
    not_utf8 = "is not UTF-8"
    long_name = "\u00e9" * 150 + "x"
    st, _, b = post_batch(d, [("assignment", None, b"phong"), ("image", b"m\xfcller.png", right),
                              ("image", long_name.encode() + b".png", right), ("student", None, b"\xff\xfe"),
                              ("image", "a.png", right), ("image", "bob.png", right)])
    check(st == 202, "form names not UTF-8: %d %r" % (st, b[:200]))
    rows = ends(d, json.loads(b).get("id", "x") if st == 202 else "x", "form names not UTF-8")
    check(not_utf8 in (rows.get("m%FCller") or {}).get("error", ""), "the Latin-1 file name's row: %r" % rows.keys())
    check(not_utf8 in (rows.get("%FF%FE") or {}).get("error", ""), "the student field's row: %r" % rows.keys())
    check((rows.get("\u00e9" * 127) or {}).get("pass") is True, "the long name, cut at a character: %r" %
          [k[:8] for k in rows])
    check((rows.get("bob") or {}).get("pass") is True, "bob beside them: %r" % rows.get("bob"))
    t = io.BytesIO()
    with tarfile.open(fileobj=t, mode="w", format=tarfile.USTAR_FORMAT, encoding="latin-1") as tf:
        for n in ("m\u00fcller.png", "bob.png"):
            info = tarfile.TarInfo(n)
            info.size = len(right)
            tf.addfile(info, io.BytesIO(right))
    st, _, b = post_batch(d, [("assignment", None, b"phong"), ("archive", "class.tar", t.getvalue())])
    check(st == 202 and json.loads(b).get("total") == 2, "a tar with a Latin-1 name: %d %r" % (st, b[:200]))
    rows = ends(d, json.loads(b).get("id", "x") if st == 202 else "x", "a tar with a Latin-1 name")
    check(not_utf8 in (rows.get("m%FCller") or {}).get("error", ""), "the tar's Latin-1 name: %r" % rows)
    body, ct = form_parts([("assignment", None, b"phong"), ("student", None, b"\xff\xfe"), ("image", "a.png", right)])
    st, _, v = d.request("POST", "/v1/grade", body=body, headers={"Content-Type": ct})
    check(st == 400 and b"not UTF-8" in v, "a single grade whose student is not UTF-8: %d %r" % (st, v[:200]))


def limits(d, images):
    bomb = io.BytesIO()
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("zeros.png", b"\0" * (64 << 20))
    st, _, b = post_batch(d, [("assignment", None, b"phong"), ("archive", "bomb.zip", bomb.getvalue())])
    check(st == 413 and (b"--max-batch-expanded" in b or b"--max-body-bytes" in b),
          "a zip bomb (%d bytes) answers %d %r" % (len(bomb.getvalue()), st, b[:200]))
    right = images["alice"][0]
    many = [("assignment", None, b"phong")] + [("image", "s%d.png" % i, right) for i in range(9)]
    st, _, b = post_batch(d, many)
    check(st == 413 and b"--max-batch-images" in b, "9 images over --max-batch-images 8: %d %r" % (st, b[:200]))
    st, _, b = post_batch(d, [("assignment", None, b"phong"), ("image", "x.png", right), ("image", "x.png", right)])
    check(st == 400, "two images of one student: %d %r" % (st, b[:200]))
    st, _, b = post_batch(d, [("assignment", None, b"nosuch"), ("image", "x.png", right)])
    check(st == 404, "an unknown assignment: %d %r" % (st, b[:200]))
    st, _, b = post_batch(d, [("assignment", None, b"phong")])
    check(st == 400, "a batch without images: %d %r" % (st, b[:200]))


def records(d, by, images):
    body, ct = form_parts([("assignment", None, b"phong"), ("student", None, b"zoe"),
                           ("image", "upload.png", images["alice"][0])])
    st, _, v = d.request("POST", "/v1/grade", body=body, headers={"Content-Type": ct})
    check(st == 200 and json.loads(v).get("student") == "zoe", "a single grade with a student: %d %r" % (st, v[:200]))
    st, _, b = d.request("GET", "/v1/grades?assignment=phong", headers=AUTH)
    grades = json.loads(b).get("grades", []) if st == 200 else []
    check(st == 200 and len(grades) >= 16, "GET /v1/grades?assignment=phong: %d, %d records" % (st, len(grades)))
    check(any(g["student"] == "zoe" for g in grades), "the single grade is not among the records")
    st, _, b = d.request("GET", "/v1/grades?student=alice", headers=AUTH)
    alice = json.loads(b).get("grades", []) if st == 200 else []
    check(len(alice) == 3 and all(g["pass"] for g in alice), "alice's records: %r" % alice)
    st, _, b = d.request("GET", "/v1/grades?since=2100-01-01T00:00:00Z", headers=AUTH)
    check(st == 200 and json.loads(b).get("grades") == [], "records since 2100: %d %r" % (st, b[:100]))
    st, _, b = d.request("GET", "/v1/grades?since=yesterday", headers=AUTH)
    check(st == 400, "since=yesterday answers %d" % st)
    st, h, b = d.request("GET", "/v1/grades?student=bob", headers=dict(AUTH, Accept="text/csv"))
    rows = list(csv.reader(io.StringIO(b.decode())))
    check(st == 200 and rows[0] == COLUMNS and len(rows) == 4, "the CSV of bob's records: %r" % rows)
    st, _, _ = d.request("GET", "/v1/grades")
    check(st == 401, "the records without a token answer %d" % st)


def after_restart(tmp, bid, by, flags):
    with Daemon(tmp, flags) as d:
        r = by["alice"]
        st, _, v = d.request("GET", "/v1/grades/" + r["grade_id"])
        check(st == 200 and json.loads(v).get("pass") is True, "alice's verdict after a restart: %d" % st)
        st, _, diff = d.request("GET", "/v1/grades/%s/diff.png" % by["bob"]["grade_id"])
        check(st == 200 and diff.startswith(b"\x89PNG"), "bob's diff after a restart: %d" % st)
        done = wait_batch(d, bid, 5)
        check(done.get("status") == "done" and len(done.get("results", [])) == 5, "the batch after a restart: %r" %
              {k: done.get(k) for k in ("status", "done")})


def hundred(tmp, flags, right):
    with Daemon(tmp, flags + ["--max-batch-images", "500"]) as d:
        parts = [("assignment", None, b"phong")] + [("image", "s%03d.png" % i, right) for i in range(100)]
        t0 = time.time()
        st, _, b = post_batch(d, parts)
        bid = json.loads(b).get("id") if st == 202 else "x"
        done = wait_batch(d, bid, 300)
        secs = time.time() - t0
        check(done.get("status") == "done" and sum(1 for r in done.get("results", []) if r.get("pass")) == 100,
              "the batch of 100: %r" % {k: done.get(k) for k in ("status", "done")})
        print("grade batch: 100 320x240 images graded in %.2f s (POST to done, reference included)" % secs)


def large_form(tmp, tokens):
    """450 image parts of 24,745 bytes: libmicrohttpd starts the part of
    s338 with an empty call at offset 0 and gives its bytes at offset 0
    again; it is one image all the same, not two of one student."""
    flags = ["--instructor-tokens", tokens, "--data-dir", os.path.join(tmp, "data-large"), "--max-batch-images",
             "500", "--max-batch-bytes", "100000000"]
    with Daemon(tmp, flags) as d:
        parts = [("assignment", None, b"phong")] + [("image", "s%03d.png" % i, b"x" * 24745) for i in range(450)]
        st, _, b = post_batch(d, parts)
        check(st == 202 and json.loads(b).get("total") == 450, "450 image parts: %d %r" % (st, b[:200]))
        if st == 202:
            rows = ends(d, json.loads(b)["id"], "450 image parts")
            check(len(rows) == 450 and all("not a PNG" in (r.get("error") or "") for r in rows.values()),
                  "450 image parts: %d rows" % len(rows))


def killed_mid_batch(tmp, tokens, right):
    """kill -9 while a batch of 400 grades, then a restart under the same
    --daemon-id on the same store: the batch ends, done == total, the rows
    graded before the kill kept and every other student an error row saying
    the daemon restarted."""
    data = os.path.join(tmp, "data-k9")
    flags = ["--instructor-tokens", tokens, "--data-dir", data, "--threads", "2", "--max-batch-images", "500",
             "--max-batch-bytes", "100000000", "--daemon-id", "batch-k9"]
    names = ["s%03d" % i for i in range(400)]
    with Daemon(tmp, flags) as d:
        st, _, b = post_batch(d, [("assignment", None, b"phong")] + [("image", n + ".png", right) for n in names])
        check(st == 202, "a batch of 400: %d %r" % (st, b[:200]))
        bid = json.loads(b).get("id", "x") if st == 202 else "x"
        before = {}
        for _ in range(600):
            st, _, b = d.request("GET", "/v1/grade/batch/" + bid, headers=AUTH)
            before = json.loads(b) if st == 200 else {}
            if before.get("done", 0) >= 20 or before.get("status") != "running":
                break
            time.sleep(0.01)
        d.proc.kill()
        d.proc.wait()
    check(before.get("status") == "running" and 0 < before.get("done", 0) < 400,
          "the batch was not mid-way when killed: %r" % {k: before.get(k) for k in ("status", "done")})
    with Daemon(tmp, flags) as d:
        done = wait_batch(d, bid, 30)
        rows = done.get("results", [])
        graded = [r for r in rows if not r.get("error")]
        restarted = [r for r in rows if "restarted" in (r.get("error") or "")]
        check(done.get("status") == "done" and done.get("done") == done.get("total") == 400 and len(rows) == 400,
              "after kill -9 and a restart: %r" % {k: done.get(k) for k in ("status", "total", "done")})
        check(sorted(r["student"] for r in rows) == names and len(graded) + len(restarted) == 400 and
              len(graded) >= before.get("done", 0),
              "after kill -9: %d graded (%d before the kill), %d rows saying the daemon restarted" %
              (len(graded), before.get("done", 0), len(restarted)))
        print("grade batch: killed -9 at %d/400; after the restart %s %d/%d, %d graded rows kept, %d error rows" %
              (before.get("done", 0), done.get("status"), done.get("done", 0), done.get("total", 0), len(graded),
               len(restarted)))


def vm_mib(pid, key):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith(key):
                return int(line.split()[1]) // 1024
    return 0


def bombs_within_budget(tmp, tokens):
    """Four concurrent archives that each expand past --max-batch-expanded
    (256 MiB): they are expanded by the render queue only as
    --memory-budget (640 MiB) allows, so the daemon's peak resident set
    stays within the budget, and /healthz answers at once meanwhile."""
    budget = 640
    flags = ["--instructor-tokens", tokens, "--data-dir", os.path.join(tmp, "data-bombs"), "--threads", "2",
             "--memory-budget", str(budget << 20), "--max-batch-expanded", str(256 << 20)]
    bomb = io.BytesIO()
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as zf:
        for i in range(40):
            zf.writestr("s%02d.png" % i, b"\0" * (15 << 20))
    body, ct = form_parts([("assignment", None, b"phong"), ("archive", "bomb.zip", bomb.getvalue())])
    # Under AddressSanitizer, freed blocks wait in its quarantine (256 MiB
    # by default): memory the daemon gave back, which is not what is measured.
    asan = ":".join(o for o in (os.environ.get("ASAN_OPTIONS"), "quarantine_size_mb=0") if o)
    with Daemon(tmp, flags, env={"ASAN_OPTIONS": asan}) as d:
        answers, worst, peak, stop = [], [0.0], [0], [False]

        def one():
            st, _, b = d.request("POST", "/v1/grade/batch", body=body, headers=dict(AUTH, **{"Content-Type": ct}))
            answers.append((st, b"--max-batch-expanded" in b))

        def watch():
            while not stop[0]:
                peak[0] = max(peak[0], vm_mib(d.pid, "VmRSS"))
                t = time.time()
                d.request("GET", "/healthz", timeout=30)
                worst[0] = max(worst[0], time.time() - t)
                time.sleep(0.02)

        w = threading.Thread(target=watch)
        w.start()
        posts = [threading.Thread(target=one) for _ in range(4)]
        for t in posts:
            t.start()
        for t in posts:
            t.join()
        stop[0] = True
        w.join()
        hwm = vm_mib(d.pid, "VmHWM")
        check(answers == [(413, True)] * 4, "four bombs: %r" % answers)
        check(hwm < budget, "four bombs: VmHWM %d MiB, over the budget of %d MiB" % (hwm, budget))
        check(worst[0] < 0.5, "four bombs: /healthz took %.2f s" % worst[0])
        print("grade batch: 4 concurrent bombs, budget %d MiB: VmHWM %d MiB (sampled RSS %d MiB), slowest /healthz "
              "%.3f s" % (budget, hwm, peak[0], worst[0]))


def form_words(tmp, tokens, right):
    """Every form's limits answered in the same words, naming its flag;
    an unknown batch is a batch's 404, not a job's."""
    flags = ["--instructor-tokens", tokens, "--data-dir", os.path.join(tmp, "data-words"),
             "--max-body-bytes", "200000", "--max-code-bytes", "4096"]
    big, name = b"x" * 300000, b"n" * 100

    def post(path, parts, headers=None):
        body, ct = form_parts(parts)
        return d.request("POST", path, body=body, headers=dict(headers or {}, **{"Content-Type": ct}))

    def said(b):
        try:
            return json.loads(b).get("error", {})
        except ValueError:
            return {}
    with Daemon(tmp, flags) as d:
        over = "the 'image' part is over the limit of 200000 bytes (--max-body-bytes)"
        for path, parts, headers in (("/v1/grade", [("assignment", None, b"phong"), ("image", "a.png", big)], None),
                                     ("/v1/grade/batch", [("assignment", None, b"phong"), ("image", "a.png", big)],
                                      AUTH)):
            st, _, b = post(path, parts, headers)
            check(st == 413 and said(b).get("code") == "too_large" and said(b).get("message") == over,
                  "%s, an image over --max-body-bytes: %d %r" % (path, st, b[:200]))
        long_name = "the 'assignment' field is longer than an assignment name can be"
        for path, headers in (("/v1/grade", None), ("/v1/grade/batch", AUTH), ("/v1/grade/code", None)):
            st, _, b = post(path, [("assignment", None, name), ("image", "a.png", right)], headers)
            check(st == 400 and said(b).get("message") == long_name,
                  "%s, an assignment name too long: %d %r" % (path, st, b[:200]))
            nameless = b"--XyZ\r\nContent-Disposition: form-data\r\n\r\nx\r\n--XyZ--\r\n"
            st, _, b = d.request("POST", path, body=nameless,
                                 headers=dict(headers or {}, **{"Content-Type": "multipart/form-data; boundary=XyZ"}))
            check(st == 400 and "no field name" in said(b).get("message", ""),
                  "%s, a part without a name: %d %r" % (path, st, b[:200]))
        code = [("assignment", None, b"phong"), ("source", "PhongMaterial.h", b"/" * 5000)]
        st, _, b = post("/v1/grade/code", code)
        check(st == 413 and said(b).get("message") ==
              "the 'source' part is over the limit of 4096 bytes (--max-code-bytes)",
              "a source over --max-code-bytes: %d %r" % (st, b[:200]))
        two = [("assignment", None, b"phong"), ("source", "a.h", b"//"), ("code", "b.h", b"//")]
        st, _, b = post("/v1/grade/code", two)
        check(st == 400 and said(b).get("message") == "the form has more than one 'source' file",
              "two source files: %d %r" % (st, b[:200]))
        st, _, b = post("/v1/grade/code", [("assignment", None, b"phong"), ("source", "a.h", b"/" * 100000)])
        check(st == 413 and "--max-code-bytes" in said(b).get("message", "") and
              "--max-body-bytes" not in said(b).get("message", ""),
              "a code form over its Content-Length bound names --max-code-bytes: %d %r" % (st, b[:200]))
        no_batch = "no batch with that id (batches expire with their grades, see --grade-ttl)"
        for path in ("/v1/grade/batch/0123456789abcdef0123456789abcdef", "/v1/grade/batch/" + "a" * 200,
                     "/v1/grade/batch/nosuch/results.csv", "/v1/grade/batch/nosuch/results.json"):
            st, _, b = d.request("GET", path, headers=AUTH)
            check(st == 404 and said(b).get("code") == "not_found" and said(b).get("message") == no_batch,
                  "GET %s: %d %r" % (path[:60], st, b[:200]))


def main():
    tmp = tempfile.mkdtemp(prefix="rayd-batch-")
    try:
        gate(tmp)
        tokens = os.path.join(tmp, "tokens")
        with open(tokens, "w") as f:
            f.write("# the course's instructors\n%s\n\n" % TOKEN)
        images = class_images(tmp)
        data = os.path.join(tmp, "data")
        flags = ["--instructor-tokens", tokens, "--data-dir", data, "--threads", "2"]
        with Daemon(tmp, flags + ["--max-batch-images", "8", "--max-batch-expanded", "16000000"]) as d:
            bid, by = image_batch(d, images)
            archive_batches(d, images)
            limits(d, images)
            records(d, by, images)
            utf8_names(d, images)
            names_not_utf8(d, images)
            hostile_archives(d)
        after_restart(tmp, bid, by, flags)
        hundred(tmp, ["--instructor-tokens", tokens, "--data-dir", os.path.join(tmp, "data100")],
                images["alice"][0])
        large_form(tmp, tokens)
        killed_mid_batch(tmp, tokens, images["alice"][0])
        bombs_within_budget(tmp, tokens)
        form_words(tmp, tokens, images["alice"][0])
    finally:
        if not check.failed:
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            print("grade batch: the logs are in %s" % tmp, file=sys.stderr)
    return check.summary()


if __name__ == "__main__":
    sys.exit(main())
