"""Section 11, grading code: what a student's calcReflectedLight costs from
upload to verdict (docs/grading.md, "Grading code").

1. One at a time: POST /v1/grade/code of tests/codegrade/students/
   phong_ok.h (the phong assignment, 18 944 shading calls) and diffuse_ok.h
   (the diffuse one, more calls: every surface is diffuse), --runs x 5
   grades each after a first one that renders and caches the reference; per
   grade the wall time at the client and the parts the answer reports: the
   compile, the calls (3223 or 2823 configurations and the image's), the
   whole sandbox (bubblewrap's start and stop, copying the files in, the
   compile, the calls) and the daemon's total (the sandbox plus rendering the
   assignment twice on one thread, recording and replaying, and grading the
   image). The median of each.
2. The sandbox alone: a file that does not compile (a syntax error on its
   first line): the compiler gives up at once, so the sandbox's time is
   bwrap's start, the copies and g++'s start.
3. Two clients at once on a daemon with --max-code-jobs 2 and --threads 2,
   each posting phong_ok.h --runs x 5 times back to back: grades per second
   against one client's.

The daemon, the sandbox's compiler and the clients share this machine's
cores."""
import json
import os
import statistics
import threading
import time
import uuid

from .. import measure, report

TITLE = "grading code: a student's function from upload to verdict, its parts, two at once"
TOOLS = ("bwrap", "g++")


def form(assignment, filename, text):
    b = uuid.uuid4().hex
    body = ("--%s\r\nContent-Disposition: form-data; name=\"assignment\"\r\n\r\n%s\r\n"
            "--%s\r\nContent-Disposition: form-data; name=\"source\"; filename=\"%s\"\r\n\r\n" %
            (b, assignment, b, filename)).encode() + text + ("\r\n--%s--\r\n" % b).encode()
    return body, "multipart/form-data; boundary=" + b


def grade(server, assignment, filename, text, expect=200):
    body, ct = form(assignment, filename, text)
    status, _, data, secs = measure.request(server.url("/v1/grade/code"), "POST", body, ct, timeout=300)
    if status != expect:
        raise measure.Failed("POST /v1/grade/code of %s answered %d: %s" % (filename, status, data[:200]))
    v = json.loads(data)
    fn = v.get("function") or {}
    return {"wall_ms": secs * 1e3, "compile_ms": v["compile"]["ms"], "calls_ms": fn.get("ms"),
            "sandbox_ms": v.get("sandbox_ms"), "server_ms": v.get("ms"), "shading_calls": v.get("shading_calls"),
            "configurations": fn.get("configurations"), "pass": v.get("pass")}


def medians(runs):
    keys = ("wall_ms", "compile_ms", "calls_ms", "sandbox_ms", "server_ms")
    return {k: statistics.median(r[k] for r in runs) if all(r[k] is not None for r in runs) else None for k in keys}


def one_at_a_time(ctx, server, count):
    rows = {}
    for name, assignment, cls in (("phong_ok", "phong", "PhongMaterial"), ("diffuse_ok", "diffuse", "DiffuseMaterial")):
        text = open(os.path.join(ctx.root, "tests", "codegrade", "students", name + ".h"), "rb").read()
        first = grade(server, assignment, cls + ".h", text)
        runs = [grade(server, assignment, cls + ".h", text) for _ in range(count)]
        rows[name] = {"first": first, "runs": runs, "median": medians(runs), "shading_calls": first["shading_calls"],
                      "configurations": first["configurations"], "pass": all(r["pass"] for r in runs)}
    bad = b"this is not C++;\n"
    runs = [grade(server, "phong", "PhongMaterial.h", bad, expect=422) for _ in range(count)]
    rows["compile_error"] = {"runs": runs, "median": medians(runs)}
    return rows


def two_at_once(ctx, server, count):
    text = open(os.path.join(ctx.root, "tests", "codegrade", "students", "phong_ok.h"), "rb").read()
    grade(server, "phong", "PhongMaterial.h", text)  # the reference, cached
    t0 = time.perf_counter()
    for _ in range(count):
        grade(server, "phong", "PhongMaterial.h", text)
    one = count / (time.perf_counter() - t0)
    errors = []

    def client():
        try:
            for _ in range(count):
                grade(server, "phong", "PhongMaterial.h", text)
        except measure.Failed as e:
            errors.append(str(e))
    threads = [threading.Thread(target=client) for _ in range(2)]
    t0 = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    two = 2 * count / (time.perf_counter() - t0)
    if errors:
        raise measure.Failed(errors[0])
    return {"grades": count, "one_client_per_s": one, "two_clients_per_s": two, "ratio": two / one}


def run(ctx):
    count = (1 if ctx.quick else 5) * ctx.runs
    # two clients on one address: each its own slot
    cmd = measure.rayd_serve_cmd(ctx.rayd, "--threads", "2", "--max-code-jobs", "2", "--max-code-jobs-per-client", "2")
    print("  one at a time, %d grades each ..." % count, flush=True)
    with measure.Server(cmd, ctx.path("codegrade.log")) as s:
        alone = one_at_a_time(ctx, s, count)
    print("  two clients at once ...", flush=True)
    with measure.Server(cmd, ctx.path("codegrade2.log")) as s:
        pair = two_at_once(ctx, s, count)
    return {"settings": {"grades": count, "threads": 2, "max_code_jobs": 2}, "alone": alone, "pair": pair}


# ---------------------------------------------------------------- tables

f = report.f


def t_codegrade(sec):
    a = sec["alone"]
    rows = []
    for name, what in (("phong_ok", "phong_ok.h on phong"), ("diffuse_ok", "diffuse_ok.h on diffuse"),
                       ("compile_error", "a syntax error (422)")):
        m = a[name]["median"]
        rest = None if m["server_ms"] is None or m["sandbox_ms"] is None else m["server_ms"] - m["sandbox_ms"]
        rows.append([what, a[name].get("configurations") or "", a[name].get("shading_calls") or "",
                     f(m["wall_ms"], "%.0f"), f(m["compile_ms"], "%.0f"), f(m["calls_ms"], "%.0f"),
                     f(m["sandbox_ms"], "%.0f"), f(rest, "%.0f")])
    p = sec["pair"]
    head = ["upload", "configurations", "image's calls", "wall ms", "compile ms", "calls ms", "sandbox ms",
            "renders and grading ms"]
    return (report.table(head, rows) + "\n\nTwo clients at once (--max-code-jobs 2, --threads 2): %.2f grades/s "
            "against %.2f for one, %.2fx." % (p["two_clients_per_s"], p["one_client_per_s"], p["ratio"]))


report.MARKERS.setdefault("codegrade", ("codegrade", t_codegrade))
