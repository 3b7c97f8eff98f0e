#!/usr/bin/env python3
"""GET /metrics of a real daemon, read as Prometheus' text format 0.0.4.

Checks that the exposition is well-formed (every line a comment, HELP, TYPE
or sample; every family has HELP and TYPE before its samples, its samples
together; label values escaped; no series twice; histogram buckets
increasing, cumulative, ending in +Inf equal to _count); that the families
rayd documents are there with their types; that the counters move by
exactly what known requests did (by route and status, by class, durations,
jobs, queue wait, grades, reference cache); that the render-time buckets
reach --job-timeout-ms; that the process metrics agree with /proc; and, when
promtool is there ($PROMTOOL, on PATH, or build/tools/promtool, which
deploy/deps.sh unpacks from Debian's prometheus package), that `promtool
check metrics` accepts it.

Usage: RAYD=build/rayd /usr/bin/python3 tests/integration/metrics_test.py
(from the repository root). The daemon listens on 127.0.0.1 on a port it
picks, and is stopped by its pid.
"""
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from rayd_http import RAYD, Checks, Daemon, form, png, render_png

check = Checks("metrics")

NAME = re.compile(r"[a-zA-Z_:][a-zA-Z0-9_:]*")
LABEL = re.compile(r"[a-zA-Z_][a-zA-Z0-9_]*")
TYPES = ("counter", "gauge", "histogram", "summary", "untyped")
JOB_TIMEOUT_MS = 600000

# Every family rayd documents, with its type.
FAMILIES = {
    "rayd_queue_depth": "gauge", "rayd_jobs_running": "gauge", "rayd_jobs_total": "counter",
    "rayd_render_seconds": "histogram", "rayd_queue_wait_seconds": "histogram",
    "rayd_rays_traced_total": "counter", "rayd_result_bytes": "gauge", "rayd_jobs_kept": "gauge",
    "rayd_memory_budget_bytes": "gauge", "rayd_memory_reserved_bytes": "gauge", "rayd_grade_cache_bytes": "gauge",
    "rayd_jobs_waiting_memory": "gauge", "rayd_http_deadline_closed_total": "counter",
    "rayd_http_refused_total": "counter", "rayd_http_responses_total": "counter",
    "rayd_http_requests_total": "counter", "rayd_http_request_duration_seconds": "histogram",
    "rayd_grades_total": "counter", "rayd_grade_reference_cache_total": "counter",
    "process_cpu_seconds_total": "counter", "process_resident_memory_bytes": "gauge",
    "process_virtual_memory_bytes": "gauge", "process_open_fds": "gauge", "process_max_fds": "gauge",
    "process_start_time_seconds": "gauge", "rayd_build_info": "gauge",
    "rayd_store_queue_depth": "gauge", "rayd_store_jobs_running": "gauge",
    "rayd_farm_scenes_read_total": "counter",
}


class FormatError(Exception):
    pass


def parse_value(text):
    if text in ("+Inf", "Inf"):
        return math.inf
    if text == "-Inf":
        return -math.inf
    if text == "NaN":
        return math.nan
    if not re.fullmatch(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?", text):
        raise FormatError("not a number: %r" % text)
    return float(text)


def parse_labels(line, i):
    """The label set starting after '{' at line[i]: (dict, index after '}')."""
    labels = {}
    while True:
        if line[i] == "}":
            return labels, i + 1
        m = LABEL.match(line, i)
        if not m or line[m.end():m.end() + 2] != '="':
            raise FormatError("bad label at column %d" % i)
        name, i = m.group(0), m.end() + 2
        value = ""
        while line[i] != '"':
            if line[i] == "\\":
                esc = line[i + 1]
                if esc not in '\\"n':
                    raise FormatError("bad escape \\%s in a label value" % esc)
                value += "\n" if esc == "n" else esc
                i += 2
            elif line[i] == "\n":
                raise FormatError("newline in a label value")
            else:
                value += line[i]
                i += 1
        i += 1
        if name in labels:
            raise FormatError("label %s twice" % name)
        labels[name] = value
        if line[i] == ",":
            i += 1
        elif line[i] != "}":
            raise FormatError("expected , or } at column %d" % i)


def parse_sample(line):
    m = NAME.match(line)
    if not m:
        raise FormatError("no metric name")
    name, i, labels = m.group(0), m.end(), {}
    if i < len(line) and line[i] == "{":
        labels, i = parse_labels(line, i + 1)
    rest = line[i:]
    if not rest.startswith(" "):
        raise FormatError("no space before the value")
    parts = rest.split()
    if len(parts) not in (1, 2):
        raise FormatError("expected a value and an optional timestamp")
    if len(parts) == 2 and not re.fullmatch(r"-?\d+", parts[1]):
        raise FormatError("bad timestamp %r" % parts[1])
    return name, labels, parse_value(parts[0])


def family_of(sample, families):
    for suffix in ("_bucket", "_sum", "_count"):
        base = sample[:-len(suffix)]
        if sample.endswith(suffix) and families.get(base, {}).get("type") in ("histogram", "summary"):
            return base
    return sample


def parse(text):
    """{family: {"type", "help", "samples": [(name, labels, value)]}}; raises FormatError."""
    if not text.endswith("\n"):
        raise FormatError("the exposition does not end in a newline")
    families, done, current, seen = {}, set(), None, set()
    for n, line in enumerate(text.split("\n")[:-1], 1):
        try:
            if line.startswith("#"):
                parts = line.split(" ", 3)
                if len(parts) >= 3 and parts[1] in ("HELP", "TYPE"):
                    name = parts[2]
                    if not NAME.fullmatch(name):
                        raise FormatError("bad family name %r" % name)
                    f = families.setdefault(name, {"samples": []})
                    key = parts[1].lower()
                    if key in f:
                        raise FormatError("second %s for %s" % (parts[1], name))
                    if f["samples"]:
                        raise FormatError("%s of %s after its samples" % (parts[1], name))
                    if key == "type" and (len(parts) != 4 or parts[3] not in TYPES):
                        raise FormatError("bad TYPE line")
                    if key == "help" and re.search(r"\\[^\\n]", parts[3] if len(parts) == 4 else ""):
                        raise FormatError("bad escape in HELP")
                    f[key] = parts[3] if len(parts) == 4 else ""
                continue
            if not line.strip():
                continue
            name, labels, value = parse_sample(line)
            fam = family_of(name, families)
            if fam != current:
                if fam in done:
                    raise FormatError("samples of %s are not together" % fam)
                if current:
                    done.add(current)
                current = fam
            f = families.get(fam)
            if not f or "help" not in f or "type" not in f:
                raise FormatError("sample of %s before its HELP and TYPE" % fam)
            series = (name, tuple(sorted(labels.items())))
            if series in seen:
                raise FormatError("series %s%s twice" % series)
            seen.add(series)
            f["samples"].append((name, labels, value))
        except (FormatError, IndexError) as e:
            raise FormatError("line %d %r: %s" % (n, line, e or "truncated"))
    return families


def histogram_problems(families):
    """What is wrong with the histograms, as a list of messages."""
    problems = []
    for fam, f in families.items():
        if f["type"] != "histogram":
            continue
        groups = {}
        for name, labels, v in f["samples"]:
            key = tuple(sorted((k, x) for k, x in labels.items() if k != "le"))
            g = groups.setdefault(key, {"buckets": [], "sum": None, "count": None})
            if name == fam + "_bucket" and "le" in labels:
                g["buckets"].append((parse_value(labels["le"]), v))
            elif name in (fam + "_sum", fam + "_count"):
                g[name[len(fam) + 1:]] = v
            else:
                problems.append("%s: sample %s is not a bucket, sum or count" % (fam, name))
        for key, g in groups.items():
            what, b = "%s%s" % (fam, dict(key)), g["buckets"]
            if not b or b[-1][0] != math.inf:
                problems.append("%s: the last bucket is not +Inf" % what)
            if any(b[i][0] >= b[i + 1][0] for i in range(len(b) - 1)):
                problems.append("%s: le not increasing" % what)
            if any(b[i][1] > b[i + 1][1] for i in range(len(b) - 1)):
                problems.append("%s: buckets not cumulative" % what)
            if g["count"] is None or not b or b[-1][1] != g["count"]:
                problems.append("%s: +Inf is not _count" % what)
            if g["sum"] is None or g["sum"] < 0:
                problems.append("%s: no _sum, or a negative one" % what)
    return problems


def problems_of(text):
    try:
        return histogram_problems(parse(text))
    except FormatError as e:
        return [str(e)]


def check_the_checker():
    """The parser refuses what it must: each of these is broken one way."""
    label = r'x="q\"\\\n"'  # a quote, a backslash and a newline, escaped
    ok = ("# HELP a_total A.\n# TYPE a_total counter\na_total{%s} 1\n"
          "# HELP h H.\n# TYPE h histogram\n"
          'h_bucket{le="1"} 1\nh_bucket{le="+Inf"} 2\nh_sum 3\nh_count 2\n') % label
    check(problems_of(ok) == [], "a good exposition was refused: %s" % problems_of(ok))
    check(parse(ok)["a_total"]["samples"][0][1] == {"x": 'q"\\\n'}, "label escapes read wrong")
    broken = {
        "no HELP": ok.replace("# HELP a_total A.\n", ""),
        "no TYPE": ok.replace("# TYPE h histogram\n", ""),
        "an unescaped quote": ok.replace(label, 'x="q""'),
        "a bad escape": ok.replace(label, r'x="q\t"'),
        "no value": ok.replace("{%s} 1" % label, "{%s}" % label),
        "a bad value": ok.replace("h_sum 3", "h_sum three"),
        "buckets not cumulative": ok.replace('h_bucket{le="1"} 1', 'h_bucket{le="1"} 3'),
        "+Inf not _count": ok.replace("h_count 2", "h_count 5"),
        "no +Inf": ok.replace('h_bucket{le="+Inf"} 2\n', ""),
        "a series twice": ok + "h_count 2\n",
        "a family split": ok + 'a_total{x="r"} 1\n',
        "no final newline": ok[:-1],
    }
    for what, text in broken.items():
        check(text != ok and problems_of(text) != [], "the parser took an exposition with %s" % what)


def scrape(d):
    status, headers, body = d.request("GET", "/metrics")
    check(status == 200, "/metrics answered %d" % status)
    check(headers.get("content-type", "").startswith("text/plain; version=0.0.4"),
          "/metrics Content-Type %s" % headers.get("content-type"))
    text = body.decode()
    try:
        families = parse(text)
    except FormatError as e:
        check(False, "the exposition is malformed: %s" % e)
        sys.exit(check.summary())
    check(True, "well-formed")
    for p in histogram_problems(families):
        check(False, p)
    return text, families


def value(families, fam, sample=None, **labels):
    """A sample's value; 0 when the series is not there (yet)."""
    sample = sample or fam
    for name, lab, v in families.get(fam, {}).get("samples", []):
        if name == sample and lab == labels:
            return v
    return 0


def check_families(families):
    for fam, typ in FAMILIES.items():
        f = families.get(fam)
        check(f is not None, "family %s missing" % fam)
        if f:
            check(f["type"] == typ, "%s is a %s, not a %s" % (fam, f["type"], typ))
            check(f["help"].strip() != "", "%s has an empty HELP" % fam)


def check_buckets_reach_timeout(families):
    for fam in ("rayd_render_seconds", "rayd_queue_wait_seconds"):
        samples = families.get(fam, {}).get("samples", [])
        bounds = [parse_value(l["le"]) for n, l, v in samples if n == fam + "_bucket"]
        finite = [b for b in bounds if b != math.inf]
        check(finite and finite[0] == 0.005, "%s starts at %s" % (fam, finite[:1]))
        check(finite and finite[-1] >= JOB_TIMEOUT_MS / 1e3,
              "%s: the last finite bucket %s does not reach --job-timeout-ms %d" %
              (fam, finite[-1:], JOB_TIMEOUT_MS))


def proc_stat(pid):
    """(utime+stime s, start time s since the epoch, vsize, rss bytes) from /proc, as the clients read it."""
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    tck, page = os.sysconf("SC_CLK_TCK"), os.sysconf("SC_PAGESIZE")
    with open("/proc/stat") as f:
        btime = next(float(l.split()[1]) for l in f if l.startswith("btime "))
    # fields[0] is the state, field 3 of proc(5)
    return ((int(fields[11]) + int(fields[12])) / tck, btime + int(fields[19]) / tck, int(fields[20]),
            int(fields[21]) * page)


def check_process(families, pid):
    cpu, start, vsize, rss = proc_stat(pid)
    got_start = value(families, "process_start_time_seconds")
    check(abs(got_start - start) < 0.02, "process_start_time_seconds %s, /proc says %s" % (got_start, start))
    check(time.time() - 600 < got_start <= time.time() + 1, "process_start_time_seconds %s is not recent" % got_start)
    check(0 <= value(families, "process_cpu_seconds_total") <= cpu + 0.01,
          "process_cpu_seconds_total %s, /proc says %s" % (value(families, "process_cpu_seconds_total"), cpu))
    got_rss = value(families, "process_resident_memory_bytes")
    check(0.5 * rss < got_rss < 2 * rss, "process_resident_memory_bytes %s, /proc says %s" % (got_rss, rss))
    got_vsize = value(families, "process_virtual_memory_bytes")
    check(0.5 * vsize < got_vsize < 2 * vsize and got_vsize >= got_rss,
          "process_virtual_memory_bytes %s, /proc says %s" % (got_vsize, vsize))
    fds = len(os.listdir("/proc/%d/fd" % pid))
    got_fds = value(families, "process_open_fds")
    check(abs(got_fds - fds) <= 4, "process_open_fds %s, /proc/%d/fd has %d" % (got_fds, pid, fds))
    with open("/proc/%d/limits" % pid) as f:
        soft = next(l.split()[3] for l in f if l.startswith("Max open files"))
    check(str(int(value(families, "process_max_fds"))) == soft,
          "process_max_fds %s, /proc/%d/limits says %s" % (value(families, "process_max_fds"), pid, soft))


def check_build_info(families):
    version = subprocess.run([RAYD, "--version"], capture_output=True, text=True).stdout.split()[-1]
    samples = families.get("rayd_build_info", {}).get("samples", [])
    check(len(samples) == 1 and samples[0][1] == {"version": version} and samples[0][2] == 1,
          "rayd_build_info %s, expected version %s" % (samples, version))


SCENE = ("[render]\nwidth = 16\nheight = 12\n[light]\ntype = point\nposition = 0 5 5\ncolor = 1 1 1\n"
         "[material m]\ntype = diffuse\nkd = 0.5 0.5 0.5\n[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = m\n")


def known_requests(d, tmp):
    """Requests whose effect on the counters is known; the expected deltas."""
    d.request("GET", "/no/such/route")
    d.request("GET", "/healthz")
    d.request("GET", "/healthz")
    d.request("POST", "/healthz", body=b"")
    st, _, _ = d.request("POST", "/v1/render?width=8&height=8", body=SCENE.encode(),
                         headers={"Content-Type": "text/x-rayd-cfg"})
    check(st == 200, "the render answered %d" % st)
    st, _, _ = d.request("POST", "/v1/render?width=0", body=SCENE.encode(), headers={"Content-Type": "text/plain"})
    check(st == 400, "width=0 answered %d" % st)
    st, _, _ = d.request("GET", "/healthz?" + "&".join("a%d=1" % i for i in range(70)))
    check(st == 431, "70 query arguments answered %d" % st)
    scene_path = os.path.join(tmp, "small.cfg")
    with open(scene_path, "w") as f:
        f.write(SCENE)
    good = render_png(scene_path, os.path.join(tmp, "small.png"))
    wrong = png(16, 12, lambda x, y: (255, 0, 255))
    verdicts = []
    for image in (good, wrong, png(4, 3, lambda x, y: (0, 0, 0))):
        body, ctype = form({"scene": SCENE.encode(), "image": image})
        st, _, _ = d.request("POST", "/v1/grade", body=body, headers={"Content-Type": ctype})
        verdicts.append(st)
    check(verdicts == [200, 200, 422], "the grades answered %s" % verdicts)
    requests = {("404", "other"): 1, ("200", "/healthz"): 2, ("405", "/healthz"): 1, ("200", "/v1/render"): 1,
                ("400", "/v1/render"): 1, ("431", "other"): 1, ("200", "/v1/grade"): 2, ("422", "/v1/grade"): 1,
                ("200", "/metrics"): 1}
    durations = {"other": 1, "/healthz": 3, "/v1/render": 2, "/v1/grade": 3, "/metrics": 1}
    return requests, durations


def check_deltas(before, after, requests, durations):
    def delta(fam, sample=None, **labels):
        return value(after, fam, sample, **labels) - value(before, fam, sample, **labels)

    for (code, route), n in requests.items():
        got = delta("rayd_http_requests_total", code=code, route=route)
        check(got == n, "rayd_http_requests_total{code=%s,route=%s} grew by %s, not %d" % (code, route, got, n))
    total = sum(delta("rayd_http_requests_total", **dict(l)) for l in
                {tuple(sorted(l.items())) for _, l, _ in after.get("rayd_http_requests_total", {}).get("samples", [])})
    check(total == sum(requests.values()), "rayd_http_requests_total grew by %s in all, not %d" %
          (total, sum(requests.values())))
    for cls in "12345":
        want = sum(n for (code, _), n in requests.items() if code[0] == cls)
        got = delta("rayd_http_responses_total", code=cls + "xx")
        check(got == want, "rayd_http_responses_total{code=%sxx} grew by %s, not %d" % (cls, got, want))
    fam = "rayd_http_request_duration_seconds"
    for route, n in durations.items():
        got = delta(fam, fam + "_count", route=route)
        check(got == n, "%s_count{route=%s} grew by %s, not %d" % (fam, route, got, n))
        check(delta(fam, fam + "_sum", route=route) > 0, "%s_sum{route=%s} did not grow" % (fam, route))
    for fam, labels, n in (("rayd_jobs_total", {"outcome": "done"}, 3), ("rayd_jobs_total", {"outcome": "failed"}, 1),
                           ("rayd_grades_total", {"verdict": "pass"}, 1), ("rayd_grades_total", {"verdict": "fail"}, 1),
                           ("rayd_grades_total", {"verdict": "error"}, 1),
                           ("rayd_grade_reference_cache_total", {"result": "miss"}, 1),
                           ("rayd_grade_reference_cache_total", {"result": "hit"}, 1)):
        got = delta(fam, **labels)
        check(got == n, "%s%s grew by %s, not %d" % (fam, labels, got, n))
    # One render; the grades: the first renders its reference, the second
    # finds it cached, the third fails on the image before starting.
    for fam, n in (("rayd_render_seconds", 3), ("rayd_queue_wait_seconds", 3)):
        got = delta(fam, fam + "_count")
        check(got == n, "%s_count grew by %s, not %d" % (fam, got, n))
    check(delta("rayd_rays_traced_total") > 0, "rayd_rays_traced_total did not grow")
    check(delta("process_cpu_seconds_total") >= 0, "process_cpu_seconds_total went down")


def check_stored_job(d, before):
    """A stored job ended here counts in the same histograms as a synchronous
    render, and the store's queue has its own gauges."""
    st, _, body = d.request("POST", "/v1/jobs?width=8&height=8", body=SCENE.encode(),
                            headers={"Content-Type": "text/x-rayd-cfg"})
    check(st == 202, "the stored job answered %d" % st)
    if st != 202:
        return
    job = json.loads(body)
    _, mid = scrape(d)
    check(value(mid, "rayd_store_queue_depth") + value(mid, "rayd_store_jobs_running") <= 1,
          "the store's queue holds more than the one job")
    status = None
    for _ in range(600):
        status = json.loads(d.request("GET", "/v1/jobs/" + job["id"])[2])["status"]
        if status not in ("queued", "running"):
            break
        time.sleep(0.05)
    check(status == "done", "the stored job ended %s" % status)
    _, after = scrape(d)
    for fam in ("rayd_render_seconds", "rayd_queue_wait_seconds"):
        got = value(after, fam, fam + "_count") - value(before, fam, fam + "_count")
        check(got == 1, "%s_count grew by %s for the stored job, not 1" % (fam, got))
    got = value(after, "rayd_jobs_total", outcome="done") - value(before, "rayd_jobs_total", outcome="done")
    check(got == 1, "rayd_jobs_total{outcome=done} grew by %s for the stored job, not 1" % got)
    got = value(after, "rayd_farm_scenes_read_total") - value(before, "rayd_farm_scenes_read_total")
    check(got == 0, "the stored job's scene was read back %s times by the daemon it was submitted to" % got)
    check(value(after, "rayd_store_queue_depth") == 0 and value(after, "rayd_store_jobs_running") == 0,
          "the store's queue is not empty once its one job is done")


def promtool(text):
    unpacked = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "build", "tools", "promtool")
    tool = os.environ.get("PROMTOOL") or shutil.which("promtool") or (unpacked if os.access(unpacked, os.X_OK) else None)
    if not tool:
        print("metrics: no promtool (deploy/deps.sh could not fetch it); the text format was checked by this "
              "test's parser only")
        return
    p = subprocess.run([tool, "check", "metrics"], input=text, capture_output=True, text=True, timeout=60)
    check(p.returncode == 0 and not p.stdout.strip() and not p.stderr.strip(),
          "promtool check metrics: exit %d\n%s%s" % (p.returncode, p.stdout, p.stderr))
    print("metrics: promtool check metrics: exit %d" % p.returncode)


def main():
    tmp = tempfile.mkdtemp(prefix="rayd-metrics-")
    check_the_checker()
    d = Daemon(tmp, ["--threads", "2", "--job-timeout-ms", str(JOB_TIMEOUT_MS), "--limit-samples", "16"])
    try:
        _, before = scrape(d)
        check_families(before)
        check_buckets_reach_timeout(before)
        requests, durations = known_requests(d, tmp)
        text, after = scrape(d)
        check_deltas(before, after, requests, durations)
        check_stored_job(d, after)
        check_process(after, d.pid)
        check_build_info(after)
        promtool(text)
    finally:
        rc = d.stop()
        check(rc == 0, "the daemon exited %d after SIGTERM" % rc)
    if not check.failed:
        shutil.rmtree(tmp, ignore_errors=True)
    return check.summary()


if __name__ == "__main__":
    sys.exit(main())
