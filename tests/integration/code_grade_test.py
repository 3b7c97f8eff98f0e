"""Grading students' calcReflectedLight (docs/grading.md, "Grading code"):
the CLI and POST /v1/grade/code give the same verdicts; correct code passes
(in double and in float, header or .cpp); each typical mistake fails and is
named; a compile error comes back with its file, line and column and no
sandbox path; every hostile file is contained while the daemon keeps
rendering; bad uploads are 4xx; a server whose sandbox cannot start answers
503 and renders all the same. Prints the time a code grade takes.

Run: RAYD=build/rayd python3 tests/integration/code_grade_test.py"""
import concurrent.futures
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "support"))
from rayd_http import RAYD, Checks, Daemon, form_parts, metric_value, raw_post  # noqa: E402

check = Checks("code grade")
STUDENTS = "tests/codegrade/students"
HOSTILE = "tests/codegrade/hostile"
SLOW = "tests/codegrade/slow"
CLASS = {"diffuse": "DiffuseMaterial", "phong": "PhongMaterial", "blinn_phong": "BlinnPhongMaterial",
         "cook_torrance": "CookTorranceMaterial"}
# A fixture's mistake and the cause the grader must name first.
MISTAKES = {
    "diffuse_missing_max": "missing_max", "diffuse_light_reversed": "light_reversed",
    "diffuse_ambient_inside": "ambient_inside", "diffuse_div_pi": "divided_by_pi",
    "phong_missing_max": "missing_max", "phong_reflect_sign": "reflect_sign", "phong_blinn": "blinn_not_phong",
    "phong_light_reversed": "light_reversed", "phong_ambient_inside": "ambient_inside",
    "phong_shininess_half": "shininess_wrong", "phong_no_spec_clamp": "no_specular_clamp",
    "phong_kd_missing": "kd_missing", "phong_nan": "half_vector_sign", "phong_no_max": "missing_max",
}
# phong_loop_power: s *= cos in a loop, right for the natural n that phong.grade states.
PASSING = ["diffuse_ok", "diffuse_ok_float", "phong_ok", "phong_ok_float", "phong_loop_power", "blinn_phong_ok",
           "cook_torrance_ok"]
RENDER_PROBE = b"""[render]
width = 16
height = 12

[camera]
eye = 0 0 5
target = 0 0 0

[light key]
type = point
position = 2 3 4
color = 1 1 1

[material m]
type = diffuse
kd = 0.5 0.5 0.5

[sphere]
center = 0 0 0
radius = 1
material = m
"""


def assignment_of(name):
    for a in ("cook_torrance", "blinn_phong", "diffuse", "phong"):
        if name.startswith(a):
            return a
    return "phong"


def post_code(d, assignment, filename, text, student="s1", timeout=180):
    body, ct = form_parts([("assignment", None, assignment.encode()), ("student", None, student.encode()),
                           ("source", filename, text)])
    st, h, b = d.request("POST", "/v1/grade/code", body=body, headers={"Content-Type": ct}, timeout=timeout)
    try:
        return st, h, json.loads(b)
    except ValueError:
        return st, h, {"raw": b[:200]}


def first_cause(v):
    f = v.get("function") or {}
    causes = f.get("causes") or []
    return causes[0]["cause"] if causes else None


def read(path):
    with open(path, "rb") as f:
        return f.read()


def cli(*args, timeout=300):
    return subprocess.run([RAYD, "grade"] + list(args), capture_output=True, timeout=timeout)


def cli_checks(tmp):
    t0 = time.time()
    p = cli("--assignment", "phong", "--code", STUDENTS + "/phong_ok.h", "--json", "--diff",
            os.path.join(tmp, "diff.png"))
    ms = (time.time() - t0) * 1e3
    v = json.loads(p.stdout or b"{}")
    check(p.returncode == 0 and v.get("pass") is True, "the CLI passes phong_ok (exit %d, %s)" %
          (p.returncode, p.stderr[-300:]))
    check(os.path.getsize(os.path.join(tmp, "diff.png")) > 0, "the CLI writes --diff")
    p = cli("--assignment", "phong", "--code", STUDENTS + "/phong_missing_max.h", "--json")
    v = json.loads(p.stdout or b"{}")
    check(p.returncode == 4 and first_cause(v) == "missing_max", "the CLI fails phong_missing_max with exit 4 "
          "and names missing_max (exit %d, cause %s)" % (p.returncode, first_cause(v)))
    bad = os.path.join(tmp, "PhongMaterial.h")
    with open(bad, "wb") as f:
        f.write(read(STUDENTS + "/phong_ok.h").replace(b"return diffuse + specular;", b"return diffuse +;"))
    p = cli("--assignment", "phong", "--code", bad, "--json")
    v = json.loads(p.stdout or b"{}")
    check(p.returncode == 2 and (v.get("compile") or {}).get("ok") is False and b"does not compile" in p.stderr,
          "the CLI: a compile error is exit 2 with the messages (%d)" % p.returncode)
    p = cli("--assignment", "nope", "--code", STUDENTS + "/phong_ok.h", timeout=60)
    check(p.returncode == 1 and b"nope" in p.stderr, "the CLI: no such assignment is exit 1 (%d)" % p.returncode)
    p = cli("--assignment", "phong", "--code", STUDENTS + "/phong_ok.h", "--bwrap", "/nonexistent/bwrap", timeout=60)
    check(p.returncode == 3 and b"sandbox" in p.stderr, "the CLI without a sandbox is exit 3 with why (%d, %s)" %
          (p.returncode, p.stderr[-200:]))
    cli_summaries(bad)
    return ms


def not_json(text):
    try:
        json.loads(text)
        return False
    except ValueError:
        return True


def cli_summaries(syntax_error):
    """Without --json the CLI prints a summary a student reads: the verdict
    first, each cause with its words and one example, the first compiler
    error; the same exit statuses as with --json."""
    p = cli("--assignment", "phong", "--code", STUDENTS + "/phong_missing_max.h")
    out = p.stdout.decode()
    lines = out.splitlines()
    check(p.returncode == 4 and not_json(out) and len(lines) <= 8 and lines and "fails: 300 of" in lines[0],
          "the CLI's summary of a failing grade starts with the verdict (exit %d): %s" % (p.returncode, out[:300]))
    check(len(lines) > 2 and lines[1].startswith("  missing_max, 300 configurations: Light from behind") and
          lines[2].startswith("    for example (back_lit): N (") and "expected (0, 0, 0), got (-" in lines[2],
          "the summary gives the cause, its words and one example: %s" % out[:400])
    p = cli("--assignment", "phong", "--code", STUDENTS + "/phong_ok.h")
    out = p.stdout.decode()
    check(p.returncode == 0 and out.count("\n") == 1 and out.startswith("phong (PhongMaterial): pass: 3223 of 3223"),
          "a passing grade's summary is one line (exit %d): %s" % (p.returncode, out[:300]))
    p = cli("--assignment", "phong", "--code", syntax_error)
    out = p.stdout.decode()
    check(p.returncode == 2 and "does not compile" in out and "the compiler: PhongMaterial.h:" in out,
          "a compile error's summary names the first error (exit %d): %s" % (p.returncode, out[:300]))
    p = cli("--assignment", "diffuse", "--code", STUDENTS + "/diffuse_wrong_class.h")
    out = p.stdout.decode()
    check(p.returncode == 2 and "this file defines PhongMaterial; diffuse expects DiffuseMaterial" in out and
          "adapter.cpp" not in out, "PhongMaterial.h graded as diffuse says it is the wrong class (exit %d): %s" %
          (p.returncode, out[:300]))


def students(d):
    times = []
    for name in PASSING + sorted(MISTAKES):
        a = assignment_of(name)
        t0 = time.time()
        st, _, v = post_code(d, a, CLASS[a] + ".h", read("%s/%s.h" % (STUDENTS, name)))
        times.append((time.time() - t0) * 1e3)
        if name in PASSING:
            check(st == 200 and v.get("pass") is True, "%s passes (%d: %s)" % (name, st, first_cause(v) or
                                                                             v.get("error") or v.get("note")))
        else:
            check(st == 200 and v.get("pass") is False and first_cause(v) == MISTAKES[name],
                  "%s fails naming %s (%d, got %s)" % (name, MISTAKES[name], st, first_cause(v)))
            words = ((v.get("function") or {}).get("causes") or [{}])[0].get("words", "")
            check(len(words) > 20, "%s: the cause has words for the student" % name)
            if name == "phong_no_max":
                told = " ".join(c.get("words", "") for c in (v.get("function") or {}).get("causes") or [])
                check("half vector" not in told and "wrong_value" not in json.dumps(v["function"]["causes"]),
                      "no max anywhere is told of its clamps, not of a half vector: %s" % told[:300])
    st, _, v = post_code(d, "phong_any_n", "PhongMaterial.h", read(STUDENTS + "/phong_loop_power.h"))
    causes = (v.get("function") or {}).get("causes") or [{}]
    check(st == 200 and v.get("pass") is False and [c.get("cause") for c in causes] == ["integer_power"] and
          causes[0]["example"]["material"]["shininess"] % 1 != 0,
          "a loop power where the assignment allows any n fails naming integer_power at a fractional n (%d, %s)" %
          (st, [c.get("cause") for c in causes]))
    st, _, v = post_code(d, "phong", "PhongMaterial.c", read(STUDENTS + "/phong_ok.cpp"))
    check(st == 200 and v.get("pass") is True, "a .c upload passes (%d, %s)" % (st, v.get("compile")))
    st, _, v = post_code(d, "phong", "PhongMaterial.cpp", read(STUDENTS + "/phong_ok.cpp"))
    check(st == 200 and v.get("pass") is True, "a .cpp upload passes (%d, %s)" % (st, v.get("compile")))
    img = v.get("image") or {}
    check(img.get("diff_url", "").startswith("/v1/grades/") and v.get("id") and v.get("diff_url") == img["diff_url"],
          "the image's verdict has its urls, and diff_url is beside lobe_url")
    st, h, b = d.request("GET", v.get("diff_url") or "/none")
    check(st == 200 and b.startswith(b"\x89PNG"), "the heat map is served (%d)" % st)
    _, _, v2 = post_code(d, "phong", "PhongMaterial.h", read(STUDENTS + "/phong_reflect_sign.h"))
    ex = v2["function"]["causes"][0]["example"]
    check(all(k in ex for k in ("N", "L", "V", "expected", "got", "material", "group")),
          "a cause's example has N, L, V, expected and got: %s" % sorted(ex))
    st, h, b = d.request("GET", v.get("lobe_url") or "/none")
    check(st == 200 and h.get("content-type") == "image/svg+xml" and b.startswith(b"<svg") and b"NaN" not in b,
          "the lobe plot is served (%d)" % st)
    return times


def wrong_class(d):
    """PhongMaterial.h uploaded to diffuse: 422, said in the student's terms
    first, not with the adapter's errors about the class it lacks."""
    st, _, v = post_code(d, "diffuse", "PhongMaterial.h", read(STUDENTS + "/diffuse_wrong_class.h"))
    c = v.get("compile") or {}
    err = v.get("error") or {}
    check(st == 422 and err.get("code") == "compile_error" and
          "this file defines PhongMaterial; diffuse expects DiffuseMaterial" in err.get("message", "") and
          "line" not in err, "the wrong class is the error's message (%d, %s)" % (st, err))
    check([x.get("cause") for x in c.get("causes", [])] == ["wrong_class"],
          "compile.causes names wrong_class: %s" % c.get("causes"))
    st, _, v = post_code(d, "phong", "PhongMaterial.h", read(STUDENTS + "/phong_ok.h").replace(b"+ specular;", b"+;"))
    check(st == 422 and (v.get("compile") or {}).get("causes") == [], "a syntax error has no compile cause: %s" %
          (v.get("compile") or {}).get("causes"))


def compile_error(d):
    src = read(STUDENTS + "/phong_ok.h").replace(b"return diffuse + specular;", b"return diffuse + specular")
    line = src[:src.index(b"return diffuse + specular\n")].count(b"\n") + 1
    st, _, v = post_code(d, "phong", "PhongMaterial.h", src)
    c = v.get("compile") or {}
    diags = [x for x in c.get("diagnostics", []) if x["severity"] == "error"]
    err = v.get("error") or {}
    check(st == 422 and err.get("code") == "compile_error" and v.get("pass") is False and c.get("ok") is False,
          "a syntax error is 422 compile_error with the grade (%d, %s)" % (st, err))
    check(err.get("line") in (line, line + 1) and "PhongMaterial.h" in err.get("message", ""),
          "the error names the file and line: %s" % err)
    check(diags and diags[0]["file"] == "PhongMaterial.h" and diags[0]["line"] in (line, line + 1) and
          diags[0]["column"] > 0, "the error names PhongMaterial.h:%d with a column (%s)" % (line, diags[:1]))
    check("/work" not in c.get("messages", "") and "/rayd" not in c.get("messages", ""),
          "the messages name no sandbox folder: %s" % c.get("messages", "")[:300])


def open_fds(pid):
    return len(os.listdir("/proc/%d/fd" % pid))


def descriptors(d):
    """Grades leave no descriptor open in the daemon: 30 more (code that
    does not compile, the quickest) and its /proc/PID/fd is as it was,
    give or take a connection."""
    before = open_fds(d.proc.pid)
    for i in range(30):
        post_code(d, "phong", "PhongMaterial.h", b"not C++ %d\n" % i)
    after = open_fds(d.proc.pid)
    print("code grade: daemon descriptors %d before 30 grades, %d after" % (before, after))
    check(after <= before + 2, "30 code grades leave the daemon's descriptors flat (%d before, %d after)" %
          (before, after))


def listener():
    """Something on 127.0.0.1:8080 for socket.h to reach if it could."""
    s = socket.socket()
    s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        s.bind(("127.0.0.1", 8080))
        s.listen(8)
        return s
    except OSError:
        s.close()
        return None


def hostile_expectation(name, st, v):
    """Whether the answer shows name contained; and what was seen."""
    f = v.get("function") or {}
    c = v.get("compile") or {}
    seen = "%d pass=%s compile=%s function=%s output=%s" % (st, v.get("pass"), c.get("result"),
                                                           {k: f.get(k) for k in ("crashed", "exited", "timed_out",
                                                                                  "not_run")},
                                                           (v.get("output") or {}).get("limited"))
    if name == "compile_bomb":
        return st == 422 and c.get("result") == "time_limit" and (v.get("error") or {}).get("code") == "time_limit", seen
    if name.startswith("include_") and name != "include_environ":
        msgs = c.get("messages", "")
        leaked = "root:" in msgs or "RAYD_" in msgs or socket.gethostname() in msgs
        return st == 422 and not leaked and c.get("ok") is False, seen
    if st != 200:
        return False, seen
    if name in ("read_passwd", "read_data", "socket", "alloc_100g", "fill_tmpfs", "syscall_probe", "nproc_hog"):
        return v.get("pass") is True, seen  # correct Phong unless it got out (or got 100 GB)
    if name == "include_environ":  # /proc/self/environ is the compiler's own, empty, environment
        msgs = c.get("messages", "")
        return "RAYD_" not in msgs and "PATH=" not in msgs, seen
    ok = v.get("pass") is False
    if name in ("segfault", "abort"):
        ok = ok and f.get("crashed", 0) > 0
    if name == "exit0":
        ok = ok and f.get("exited", 0) > 0
    if name == "loop":
        ok = ok and f.get("timed_out", 0) > 0
    if name == "print_forever":
        ok = ok and (v.get("output") or {}).get("limited") is True
    return ok, seen


def descendants(pid):
    """The processes below pid: a sandbox's are below its daemon (bwrap is
    the daemon's child, and what escapes a parent inside is reparented to
    bwrap's init). Not every process of uid 65534: another daemon's
    sandboxes on the same machine run as that uid too."""
    parent = {}
    for name in os.listdir("/proc"):
        try:
            with open("/proc/%s/stat" % name) as f:
                parent[int(name)] = int(f.read().rsplit(")", 1)[1].split()[1])
        except (ValueError, OSError, IndexError):
            pass
    found, todo = [], [pid]
    while todo:
        p = todo.pop()
        kids = [c for c, pp in parent.items() if pp == p]
        found += kids
        todo += kids
    return found


def hostile(d):
    lst = listener()
    probes = []
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        for path in sorted(os.listdir(HOSTILE)):
            name = path[:-2]
            fut = pool.submit(post_code, d, "phong", "PhongMaterial.h", read(os.path.join(HOSTILE, path)))
            while not fut.done():
                st, _, _ = d.request("POST", "/v1/render", body=RENDER_PROBE, timeout=60)
                probes.append(st)
                time.sleep(0.2)
            st, _, v = fut.result()
            ok, seen = hostile_expectation(name, st, v)
            check(ok, "hostile %s is contained: %s" % (name, seen))
    if lst:
        lst.close()
    check(probes and all(s == 200 for s in probes), "renders went on during the hostile grades (%d probes, %s)" %
          (len(probes), sorted(set(probes))))
    for _ in range(50):  # killed trees take a moment to be reaped
        left = descendants(d.pid)
        if not left:
            break
        time.sleep(0.1)
    check(not left, "no sandbox process is left (%s)" % left)


def the_daemons_files(d, tmp):
    """A student who knows where the daemon keeps its data and assignments
    (this test's folders) cannot include or open them."""
    data, scene = os.path.join(tmp, "var"), os.path.join(tmp, "assignments", "phong.cfg")
    ok = read(STUDENTS + "/phong_ok.h")
    inc = ok.replace(b'#include "Material.h"', b'#include "Material.h"\n#include "%s"' % scene.encode())
    st, _, v = post_code(d, "phong", "PhongMaterial.h", inc)
    msgs = (v.get("compile") or {}).get("messages", "")
    check(st == 422 and "No such file" in msgs and "shininess = 10" not in msgs and "[render]" not in msgs,
          "#include of the daemon's assignment fails without quoting it (%d: %s)" % (st, msgs[:200]))
    probe = b"""
        for (const char *p : {"%s", "%s", "%s"}) {
            int fd = open(p, O_RDONLY);
            if (fd >= 0) { close(fd); return vec3(100, 100, 100); }
        }
        Real cosAlpha""" % (data.encode(), scene.encode(), os.path.dirname(scene).encode())
    opens = ok.replace(b"        Real cosAlpha", probe, 1).replace(b'#include "Material.h"',
                                                                    b'#include "Material.h"\n#include <fcntl.h>\n#include <unistd.h>')
    st, _, v = post_code(d, "phong", "PhongMaterial.h", opens)
    check(st == 200 and v.get("pass") is True, "the daemon's data folder and assignments cannot be opened at run "
          "time (%d, pass %s, %s)" % (st, v.get("pass"), (v.get("compile") or {}).get("messages", "")[:200]))


TOKEN = "code-class-token-0123456789abcdef"


def records(d):
    """A code grade's record says the whole grade: a missing max passes the
    image but not the function, and the record fails; one that does not
    compile is an error row."""
    auth = {"Authorization": "Bearer " + TOKEN}
    st, _, v = post_code(d, "phong", "PhongMaterial.h", read(STUDENTS + "/phong_missing_max.h"), student="maxless")
    check(st == 200 and v["image"]["pass"] is True and v["pass"] is False, "phong_missing_max: the image passes, "
          "the grade fails (%d)" % st)
    post_code(d, "phong", "PhongMaterial.h", b"not C++\n", student="broken")
    st, _, b = d.request("GET", "/v1/grades?student=maxless", headers=auth)
    rows = json.loads(b).get("grades", []) if st == 200 else []
    check(len(rows) == 1 and rows[0]["pass"] is False, "maxless's record fails: %s" % rows)
    st, _, b = d.request("GET", "/v1/grades/" + v["id"])
    rec = json.loads(b) if st == 200 else {}
    check(rec.get("function", {}).get("pass") is False and rec.get("class") == "PhongMaterial",
          "the record's verdict is the code grade's (%d)" % st)
    st, _, b = d.request("GET", "/v1/grades?student=broken", headers=auth)
    rows = json.loads(b).get("grades", []) if st == 200 else []
    check(len(rows) == 1 and "compile" in (rows[0].get("error") or ""), "broken's record is an error: %s" % rows)


def bad_uploads(d):
    st, _, v = post_code(d, "phong", "PhongMaterial.h", b"x" * (64 * 1024 + 1))
    check(st == 413, "a file over --max-code-bytes is 413 (%d)" % st)
    st, _, v = post_code(d, "phong", "../PhongMaterial.h", b"int x;")
    check(st == 422 and v.get("error", {}).get("code") == "bad_code", "a path as the file's name is 422 (%d)" % st)
    st, _, v = post_code(d, "phong", "PhongMaterial.h", b"int x;\0")
    check(st == 422, "NUL bytes are 422 (%d)" % st)
    st, _, v = post_code(d, "nope", "PhongMaterial.h", b"int x;")
    check(st == 404, "an unknown assignment is 404 (%d)" % st)
    st, _, v = post_code(d, "mirror_only", "PhongMaterial.h", b"int x;")
    check(st == 422, "an assignment with no material a student writes is 422 (%d, %s)" % (st, v))
    st, _, v = post_code(d, "phong_off_domain", "PhongMaterial.h", read(STUDENTS + "/phong_ok.h"))
    err = v.get("error") or {}
    check(st == 422 and err.get("code") == "bad_assignment" and "shininess 7.5" in err.get("message", ""),
          "a scene outside the shininess its .grade states is bad_assignment (%d, %s)" % (st, err))
    st, _, v = post_code(d, "phong_bad_domain", "PhongMaterial.h", read(STUDENTS + "/phong_ok.h"))
    err = v.get("error") or {}
    check(st == 422 and err.get("code") == "bad_assignment" and "phong_bad_domain.grade:1:13" in
          err.get("message", "") and "natural or real" in err.get("message", ""),
          "a shininess that is neither natural nor real is a .grade error with its place (%d, %s)" % (st, err))
    body, ct = form_parts([("assignment", None, b"phong")])
    st, _, _ = d.request("POST", "/v1/grade/code", body=body, headers={"Content-Type": ct})
    check(st == 400, "no source file is 400 (%d)" % st)
    body, ct = form_parts([("assignment", None, b"phong"), ("code", "PhongMaterial.h", read(STUDENTS + "/phong_ok.h"))])
    st, _, b = d.request("POST", "/v1/grade/code", body=body, headers={"Content-Type": ct})
    check(st == 200 and json.loads(b).get("pass") is True, "the file may be sent as 'code' too (%d)" % st)
    st, _, _ = d.request("POST", "/v1/grade/code", body=b"{}", headers={"Content-Type": "application/json"})
    check(st == 415, "not a form is 415 (%d)" % st)
    st, _, b = d.request("GET", "/v1/grade/code/skeleton/phong")
    check(st == 200 and b"class PhongMaterial" in b, "the phong skeleton is served (%d)" % st)
    st, _, _ = d.request("GET", "/v1/grade/code/skeleton/../../etc")
    check(st == 404, "no other file is served (%d)" % st)


def busy(tmp):
    with Daemon(tmp, ["--max-code-jobs", "1", "--code-run-seconds", "4"]) as d:
        with concurrent.futures.ThreadPoolExecutor(1) as pool:
            slow = pool.submit(post_code, d, "phong", "PhongMaterial.h", read(HOSTILE + "/loop.h"))
            time.sleep(1.5)  # it is compiling or looping now
            st, h, _ = post_code(d, "phong", "PhongMaterial.h", read(STUDENTS + "/phong_ok.h"))
            check(st == 503 and h.get("retry-after"), "past --max-code-jobs is 503 with Retry-After (%d)" % st)
            check(slow.result()[0] == 200, "the running grade ends")
        st, _, v = post_code(d, "phong", "PhongMaterial.h", read(STUDENTS + "/phong_ok.h"))
        check(st == 200 and v.get("pass") is True, "then the next one runs (%d)" % st)
        _, _, m = d.request("GET", "/metrics")
        check(metric_value(m.decode(), "rayd_code_grades_total", {"verdict": "pass"}) == 1,
              "rayd_code_grades_total counts the pass")


def per_client(tmp):
    """One client cannot hold every slot, and a hang-up gives its slot back
    within a second. Two clients behind a trusted proxy, named by
    X-Forwarded-For."""
    flags = ["--max-code-jobs", "2", "--code-run-seconds", "20", "--trust-proxy", "127.0.0.1"]
    a, b = {"X-Forwarded-For": "10.0.0.1"}, {"X-Forwarded-For": "10.0.0.2"}
    slow, ok = read(SLOW + "/slow_calls.h"), read(STUDENTS + "/phong_ok.h")
    bad = b"this is not C++"

    def post(text, who, timeout=180):
        body, ct = form_parts([("assignment", None, b"phong"), ("source", "PhongMaterial.h", text)])
        st, h, _ = d.request("POST", "/v1/grade/code", body=body, headers=dict(who, **{"Content-Type": ct}),
                             timeout=timeout)
        return st, h

    with Daemon(tmp, flags) as d:
        body, ct = form_parts([("assignment", None, b"phong"), ("source", "PhongMaterial.h", slow)])
        hog = raw_post(d.port, "/v1/grade/code", body, dict(a, **{"Content-Type": ct}))
        time.sleep(1.5)  # compiling or calling now, for 20 s
        st, h = post(ok, a)
        check(st == 429 and h.get("retry-after"), "a client's second code grade is 429 with Retry-After (%d)" % st)
        st, _ = post(ok, b)
        check(st == 200, "another client still gets the other slot (%d)" % st)
        hog.close()
        t0 = time.time()
        st = 429
        while st == 429 and time.time() - t0 < 30:
            st, _ = post(bad, a)
            if st == 429:
                time.sleep(0.05)
        freed = time.time() - t0
        check(st == 422, "after hanging up the client grades again (%d)" % st)
        check(freed < 1.0, "a hang-up gave the slot back in %.2f s (at most 1 s)" % freed)
        print("code grade: a hang-up freed its slot in %.0f ms" % (freed * 1e3))


def shmem_bytes():
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("Shmem:"):
                return int(line.split()[1]) * 1024
    return 0


BUDGET = 3 << 30  # one code grade's reservation (about 2.6 GiB) fits, two do not


def memory(tmp):
    """Four grades at once of fill_tmpfs.h, which writes all it can to /,
    /dev/shm, /tmp and /work: tmpfs pages are host memory, and the host's
    (Shmem, sampled) grows by less than --memory-budget allows."""
    src = read(HOSTILE + "/fill_tmpfs.h")
    with Daemon(tmp, ["--memory-budget", str(BUDGET), "--max-code-jobs", "4", "--max-code-jobs-per-client", "4",
                          "--threads", "3"]) as d:
        base = peak = shmem_bytes()
        with concurrent.futures.ThreadPoolExecutor(4) as pool:
            futs = [pool.submit(post_code, d, "phong", "PhongMaterial.h", src, "fill%d" % i) for i in range(4)]
            while not all(f.done() for f in futs):
                peak = max(peak, shmem_bytes())
                time.sleep(0.05)
        answers = [f.result() for f in futs]
    growth = peak - base
    print("code grade: 4 fill_tmpfs grades at once, host Shmem grew %.0f MiB at most (budget %d MiB)" %
          (growth / 2**20, BUDGET >> 20))
    check(growth < BUDGET, "4 grades filling every tmpfs grow the host's Shmem by %.0f MiB, under the %d MiB "
          "budget" % (growth / 2**20, BUDGET >> 20))
    check(all(st == 200 and v.get("pass") is True for st, _, v in answers),
          "each fill_tmpfs grade ends, its writes refused, and passes: %s" % [(st, v.get("pass")) for st, _, v in answers])
    with Daemon(tmp, ["--memory-budget", str(1 << 30)]) as d:
        st, _, v = post_code(d, "phong", "PhongMaterial.h", read(STUDENTS + "/phong_ok.h"))
        check(st == 413 and "--memory-budget" in (v.get("error") or {}).get("message", ""),
              "a grade that could never fit --memory-budget is 413 (%d, %s)" % (st, v.get("error")))


def processes(tmp):
    """Not as root (the unit's DynamicUser; as root the daemon runs as 65534
    here): one student's processes up to RLIMIT_NPROC do not stop another's
    grade, and 40 render threads leave code grading on. The limit is each
    sandbox's own, not the uid's."""
    home, wrap = os.path.join(tmp, "nonroot"), []
    os.makedirs(home)
    if os.geteuid() == 0:
        os.chmod(tmp, 0o711)  # 65534 reaches its own folder inside
        os.chown(home, 65534, 65534)
        wrap = ["setpriv", "--reuid", "65534", "--regid", "65534", "--clear-groups"]
    hog, ok = read(HOSTILE + "/nproc_hog.h"), read(STUDENTS + "/phong_ok.h")
    with Daemon(home, ["--max-code-jobs", "2", "--max-code-jobs-per-client", "2"], env={"HOME": home},
                wrap=wrap) as d:
        with concurrent.futures.ThreadPoolExecutor(1) as pool:
            held = pool.submit(post_code, d, "phong", "PhongMaterial.h", hog, "hog")
            time.sleep(1.5)  # compiled, and holding its processes
            st, _, v = post_code(d, "phong", "PhongMaterial.h", ok)
            hst, _, hv = held.result()
        forked = (hv.get("output") or {}).get("text", "")
        check(st == 200 and v.get("pass") is True, "a correct grade beside one holding every process it may "
              "passes (%d, %s)" % (st, v.get("error") or v.get("note")))
        made = int(forked.split()[1]) if forked.startswith("forked ") else -1
        print("code grade: nproc_hog forked %d processes beside a correct grade (%d: pass %s)" %
              (made, st, v.get("pass")))
        check(hst == 200 and 20 <= made < 32, "nproc_hog forked up to its own sandbox's limit of 32 (%d, %r)" %
              (hst, forked[:80]))
    with Daemon(home, ["--threads", "40"], env={"HOME": home}, wrap=wrap) as d:
        st, _, v = post_code(d, "phong", "PhongMaterial.h", ok)
        check(st == 200 and v.get("pass") is True, "with --threads 40 code grading is on (%d, %s)" %
              (st, v.get("error")))


def no_sandbox(tmp):
    with Daemon(tmp, ["--bwrap", "/nonexistent/bwrap"]) as d:
        st, h, v = post_code(d, "phong", "PhongMaterial.h", read(STUDENTS + "/phong_ok.h"))
        check(st == 503 and v.get("error", {}).get("code") == "sandbox_unavailable",
              "no sandbox: 503 sandbox_unavailable (%d, %s)" % (st, v))
        st, _, _ = d.request("POST", "/v1/render", body=RENDER_PROBE)
        check(st == 200, "no sandbox: renders all the same (%d)" % st)
        check("sandbox" in d.text(), "no sandbox: the log says so")
        st, _, b = d.request("GET", "/readyz")
        why = (json.loads(b).get("unavailable") or {}).get("code_grading", "") if st == 200 else ""
        check(st == 200 and "bubblewrap" in why, "no sandbox: /readyz is 200 and names code grading as unavailable, "
              "and why (%d, %s)" % (st, b[:200]))


def assignments(tmp):
    """The bundled assignments, one with no material a student writes, and
    phong allowing a fractional shininess."""
    path = os.path.join(tmp, "assignments")
    shutil.copytree("scenes/assignments", path)
    # phong's scene where any positive shininess is allowed, as blinn_phong's
    shutil.copy(os.path.join(path, "phong.cfg"), os.path.join(path, "phong_any_n.cfg"))
    with open(os.path.join(path, "phong_any_n.grade"), "w") as f:
        f.write("title = Phong for any n\nshininess = real\n")
    # a scene whose shininess its .grade's domain excludes, and a domain that is none
    with open(os.path.join(path, "phong.cfg")) as f:
        phong = f.read()
    with open(os.path.join(path, "phong_off_domain.cfg"), "w") as f:
        f.write(phong.replace("shininess = 10\n", "shininess = 7.5\n"))
    with open(os.path.join(path, "phong_off_domain.grade"), "w") as f:
        f.write("shininess = natural\n")
    shutil.copy(os.path.join(path, "phong.cfg"), os.path.join(path, "phong_bad_domain.cfg"))
    with open(os.path.join(path, "phong_bad_domain.grade"), "w") as f:
        f.write("shininess = whole\n")
    with open(os.path.join(path, "mirror_only.cfg"), "w") as f:
        f.write(RENDER_PROBE.decode().replace("type = diffuse", "type = perfect_specular"))
    return path


def main():
    with tempfile.TemporaryDirectory() as tmp:
        cli_ms = cli_checks(tmp)
        tokens = os.path.join(tmp, "tokens")
        with open(tokens, "w") as f:
            f.write(TOKEN + "\n")
        with Daemon(tmp, ["--max-code-bytes", "65536", "--code-compile-seconds", "8", "--max-code-jobs", "2",
                          "--assignments", assignments(tmp), "--instructor-tokens", tokens]) as d:
            times = students(d)
            descriptors(d)
            compile_error(d)
            wrong_class(d)
            the_daemons_files(d, tmp)
            records(d)
            bad_uploads(d)
            hostile(d)
        busy(tmp)
        per_client(tmp)
        memory(tmp)
        processes(tmp)
        no_sandbox(tmp)
    times.sort()
    print("code grade: CLI %.0f ms (with the reference rendered); HTTP median %.0f ms, max %.0f ms over %d files" %
          (cli_ms, times[len(times) // 2], times[-1], len(times)))
    return check.summary()


if __name__ == "__main__":
    sys.exit(main())
