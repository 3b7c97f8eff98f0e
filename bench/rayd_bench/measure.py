"""Running and timing processes, and the servers of the HTTP sections.

Every figure of rayd comes from its machine-readable output: the JSON of
`rayd render --stats-format json` (last line of stderr), of `rayd compare`
(stdout), of the daemon's job status and its Prometheus /metrics. POV-Ray,
wrk and hey are other programs: their own output formats are read here.
"""
import csv
import http.client
import json
import os
import re
import signal
import subprocess
import tempfile
import threading
import time
import urllib.parse


class Failed(Exception):
    """A measured program did not do what the benchmark needs."""


class Run:
    """One finished process: exit code, wall time, peak memory, output."""

    def __init__(self, cmd, rc, wall_ms, peak_rss_kb, user_s, sys_s, stdout, stderr):
        self.cmd, self.rc, self.wall_ms, self.peak_rss_kb = cmd, rc, wall_ms, peak_rss_kb
        self.user_s, self.sys_s, self.stdout, self.stderr = user_s, sys_s, stdout, stderr

    def tail(self, n=20):
        text = (self.stdout + "\n" + self.stderr).replace("\r", "\n")
        return "\n".join(line for line in text.splitlines() if line.strip())[-4000:].splitlines()[-n:]

    def record(self):
        """What results.json keeps of a run (not its output)."""
        return {"wall_ms": round(self.wall_ms, 3), "peak_rss_kb": self.peak_rss_kb,
                "rss_floor_kb": getattr(self, "rss_floor_kb", None),
                "user_s": round(self.user_s, 3), "sys_s": round(self.sys_s, 3)}


def run(cmd, cwd=None, env=None, timeout=None, check=True, what=None):
    """Runs cmd to its end and returns a Run.

    The wall time is taken around the process alone. The peak resident set
    is the child's own (wait4's rusage, ru_maxrss in kB), so each process is
    measured apart, which getrusage(RUSAGE_CHILDREN) cannot do after the
    first child. But Linux keeps, in that figure, the resident set the child
    had before its exec: a copy of this driver's. So it is kept only when it
    is above that floor (rss_floor_kb, measured on /bin/true just before),
    and is None otherwise: the program's peak was then at most the floor.
    Output goes to temporary files, not pipes, so a chatty program cannot
    block on a full pipe. timeout (s) kills the process. With check, a
    non-zero exit raises Failed with the end of its output."""
    floor = _spawn(["true"], None, None, None)[2]
    rc, wall, ru_maxrss, user, sys_, out, err = _spawn(cmd, cwd, env, timeout)
    r = Run(list(map(str, cmd)), rc, wall, ru_maxrss if ru_maxrss > floor + 1024 else None, user, sys_, out, err)
    r.rss_floor_kb = floor
    if check and r.rc != 0:
        raise Failed("%s failed (exit %d): %s\n  %s" % (what or os.path.basename(str(cmd[0])), r.rc,
                                                      " ".join(r.cmd), "\n  ".join(r.tail())))
    return r


def _spawn(cmd, cwd, env, timeout):
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        p = subprocess.Popen(cmd, cwd=cwd, env=env, stdin=subprocess.DEVNULL, stdout=out, stderr=err)
        timer = None
        if timeout:
            timer = threading.Timer(timeout, _kill, (p.pid,))
            timer.start()
        try:
            _, status, ru = _wait4(p.pid)
        except BaseException:
            # Interrupted (SIGINT, or SIGTERM turned into SystemExit): the
            # measured program goes with the driver.
            _kill(p.pid)
            _wait4(p.pid)
            p.returncode = -signal.SIGKILL
            raise
        finally:
            if timer:
                timer.cancel()
        wall = (time.perf_counter() - t0) * 1000.0
        # Popen must not wait for a process that is already reaped.
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        return (p.returncode, wall, ru.ru_maxrss, ru.ru_utime, ru.ru_stime,
                out.read().decode("utf-8", "replace"), err.read().decode("utf-8", "replace"))


def _wait4(pid):
    while True:
        try:
            return os.wait4(pid, 0)
        except InterruptedError:
            continue


def _kill(pid):
    try:
        os.kill(pid, signal.SIGKILL)
    except ProcessLookupError:
        pass


# ---------------------------------------------------------------- rayd

def rayd_render(rayd, scene, out, width, height, threads, extra=(), cwd=None):
    """One `rayd render` with --stats-format json: (Run, statistics dict)."""
    cmd = [rayd, "render", scene, "-o", out, "--width", str(width), "--height", str(height),
           "--threads", str(threads), "--stats-format", "json"] + list(extra)
    r = run(cmd, cwd=cwd, what="rayd render")
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    try:
        stats = json.loads(lines[-1])
    except (IndexError, ValueError):
        raise Failed("rayd render printed no statistics object: %s" % "\n  ".join(r.tail()))
    if stats.get("threads") != threads:
        raise Failed("asked rayd for %d threads, it reports %s" % (threads, stats.get("threads")))
    return r, stats


def rays(stats):
    """Camera + shadow + secondary rays of a rayd statistics object."""
    return stats["camera_rays"] + stats["shadow_rays"] + stats["secondary_rays"]


def stats_record(stats):
    """A statistics object without its curve (kept short in results.json)."""
    return {k: v for k, v in stats.items() if k != "curve"}


def compare(rayd, a, b, cwd=None):
    """`rayd compare A B`: its JSON (rmse, psnr_db, max_diff, differing_pixels, ...)."""
    r = run([rayd, "compare", a, b], cwd=cwd, what="rayd compare")
    return json.loads(r.stdout)


def embree_trace(harness, scene, width, height, threads, modes=("single", "packet"), extra=(), cwd=None):
    """One run of bench/embree_trace (the rays of `rayd render --samples 1`
    traced by Embree): (Run, its JSON object: build_ms, primitives, and per
    mode and thread count the rays, hits, checksum and seconds)."""
    cmd = [harness, scene, "--width", str(width), "--height", str(height), "--threads",
           ",".join(str(t) for t in (threads if isinstance(threads, (list, tuple)) else [threads])),
           "--modes", ",".join(modes)] + list(extra)
    r = run(cmd, cwd=cwd, what="embree_trace")
    try:
        out = json.loads(r.stdout)
    except ValueError:
        raise Failed("embree_trace printed no JSON object: %s" % "\n  ".join(r.tail()))
    return r, out


# ---------------------------------------------------------------- POV-Ray

POVRAY_FLAGS = ["-D", "+Q9", "File_Gamma=1.0", "-V", "-GR", "-P"]


def povray_version():
    r = run(["povray", "--version"], check=False)
    m = re.search(r"POV-Ray \d\S*", r.stdout + r.stderr)
    return m.group(0) if m else "povray"


def _pov_seconds(text, label):
    m = None
    for m in re.finditer(r"%s:.*\(([0-9.]+) seconds\)" % re.escape(label), text):
        pass
    return float(m.group(1)) * 1000.0 if m else None


def povray(pov, out, width, height, threads, extra=("-A",), cwd=None):
    """One POV-Ray render: (Run, {parse_ms, bound_ms, trace_ms, rays, shadow_tests}).

    -D no display, +Q9 (shadows on), File_Gamma=1.0 as rayd's gamma 1,
    -V -GR less chatter, -P no pause; extra is -A (no antialiasing) unless
    the caller asks for POV-Ray's own. Its statistics are read from its
    log; "cannot open the user configuration file" is a harmless warning."""
    cmd = ["povray", "+I" + pov, "+O" + out, "+FN", "+W%d" % width, "+H%d" % height,
           "+WT%d" % threads] + list(extra) + POVRAY_FLAGS
    r = run(cmd, cwd=cwd, what="povray")
    text = (r.stdout + "\n" + r.stderr).replace("\r", "\n")
    m_rays = re.findall(r"^Rays:\s+(\d+)", text, re.M)
    m_shadow = re.findall(r"^Shadow Ray Tests:\s+(\d+)", text, re.M)
    st = {"parse_ms": _pov_seconds(text, "Parse Time"), "bound_ms": _pov_seconds(text, "Bounding Time"),
          "trace_ms": _pov_seconds(text, "Trace Time"),
          "rays": int(m_rays[-1]) if m_rays else None,
          "shadow_tests": int(m_shadow[-1]) if m_shadow else 0}
    if st["trace_ms"] is None or st["rays"] is None:
        raise Failed("no Trace Time or Rays in POV-Ray's statistics: %s" % "\n  ".join(r.tail()))
    return r, st


def povray_overhead(work, runs):
    """POV-Ray's fixed cost (front-end start-up and shut-down) on an empty
    16x9 scene, best of runs, in ms: part of each of its wall times."""
    pov = os.path.join(work, "empty.pov")
    with open(pov, "w") as f:
        f.write("#version 3.7;\ncamera { location <0, 0, -5> look_at 0 }\n")
    best = None
    for _ in range(runs):
        r = run(["povray", "+I" + pov, "-F", "+W16", "+H9", "-D", "-A", "+WT1", "-V", "-GR", "-P"],
                what="povray on an empty scene")
        best = r.wall_ms if best is None else min(best, r.wall_ms)
    return best


# ---------------------------------------------------------------- servers

def alive(pid):
    """Running, not exited and not a zombie."""
    try:
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("State:"):
                    return line.split()[1] not in ("Z", "X")
    except OSError:
        return False
    return False


def rss_fds(pid):
    """(VmRSS kB, open file descriptors) of a process, None where unreadable."""
    rss = None
    try:
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    rss = int(line.split()[1])
        fds = len(os.listdir("/proc/%d/fd" % pid))
    except OSError:
        fds = None
    return rss, fds


class Server:
    """A server on 127.0.0.1 at a port the kernel picks, as a context manager.

    cmd is a list in which the string "{port_file}" is replaced by the file
    the server must write its port to (rayd serve --port-file, bare_mhd).
    On leaving, the server is stopped by its pid: SIGTERM, up to stop_s
    seconds to exit (rayd drains for --drain-ms), then SIGKILL; rc is its
    exit status."""

    def __init__(self, cmd, log_path, start_s=10.0, stop_s=15.0):
        self.log_path, self.start_s, self.stop_s = log_path, start_s, stop_s
        self.port_file = log_path + ".port"
        self.cmd = [self.port_file if c == "{port_file}" else c for c in cmd]
        self.proc, self.port, self.rc = None, None, None

    def __enter__(self):
        if os.path.exists(self.port_file):
            os.unlink(self.port_file)
        self.log = open(self.log_path, "wb")
        self.proc = subprocess.Popen(self.cmd, stdin=subprocess.DEVNULL, stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + self.start_s
        try:
            while True:
                try:
                    with open(self.port_file) as f:
                        text = f.read().strip()
                    if text:
                        self.port = int(text)
                        break
                except (OSError, ValueError):
                    pass
                if self.proc.poll() is not None:
                    raise Failed("the server exited at start: %s\n  %s" % (" ".join(self.cmd), self.log_tail()))
                if time.monotonic() > deadline:
                    raise Failed("the server wrote no port in %g s: %s" % (self.start_s, " ".join(self.cmd)))
                time.sleep(0.05)
        except BaseException:
            self.stop()
            raise
        return self

    def __exit__(self, *exc):
        self.stop()
        return False

    @property
    def pid(self):
        return self.proc.pid

    def url(self, path=""):
        return "http://127.0.0.1:%d%s" % (self.port, path)

    def log_tail(self, n=10):
        try:
            with open(self.log_path, "rb") as f:
                return "\n  ".join(f.read().decode("utf-8", "replace").splitlines()[-n:])
        except OSError:
            return ""

    def stop(self):
        if self.proc is None or self.rc is not None:
            return self.rc
        if self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(timeout=self.stop_s)
            except subprocess.TimeoutExpired:
                os.kill(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        self.rc = self.proc.returncode
        self.log.close()
        return self.rc


def rayd_serve_cmd(rayd, *extra):
    """`rayd serve` for the bench: 127.0.0.1 only, short drain."""
    return [rayd, "serve", "--listen", "127.0.0.1:0", "--port-file", "{port_file}", "--scenes", "scenes",
            "--drain-ms", "2000"] + list(extra)


# ---------------------------------------------------------------- HTTP

def request(url, method="GET", body=None, content_type=None, timeout=60.0):
    """(status, headers dict, body bytes, seconds from connecting to the
    last byte of the answer); status 0 when the connection failed."""
    u = urllib.parse.urlsplit(url)
    t0 = time.perf_counter()
    conn = http.client.HTTPConnection(u.hostname, u.port, timeout=timeout)
    try:
        headers = {"Content-Type": content_type} if content_type else {}
        conn.request(method, u.path + ("?" + u.query if u.query else ""), body=body, headers=headers)
        resp = conn.getresponse()
        data = resp.read()
        return resp.status, {k.lower(): v for k, v in resp.getheaders()}, data, time.perf_counter() - t0
    except (OSError, http.client.HTTPException):
        return 0, {}, b"", time.perf_counter() - t0
    finally:
        conn.close()


def get_json(url, timeout=10.0):
    status, _, data, _ = request(url, timeout=timeout)
    if status != 200:
        raise Failed("GET %s answered %d" % (url, status))
    return json.loads(data)


_METRIC = re.compile(r'^([a-zA-Z_:][a-zA-Z0-9_:]*)(\{[^}]*\})?\s+(\S+)$')


def metrics(server):
    """GET /metrics (Prometheus text) as {'name' or 'name{labels}': value}."""
    status, _, data, _ = request(server.url("/metrics"), timeout=10.0)
    if status != 200:
        raise Failed("GET /metrics answered %d" % status)
    out = {}
    for line in data.decode().splitlines():
        m = _METRIC.match(line)
        if m:
            out[m.group(1) + (m.group(2) or "")] = float(m.group(3))
    return out


def wait_idle(server, limit_s=30.0):
    """Until rayd has no job queued or running (after a load generator
    stops, the jobs of its abandoned requests are cancelled). False if it
    still has some after limit_s."""
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        m = metrics(server)
        if m.get("rayd_queue_depth") == 0 and m.get("rayd_jobs_running") == 0:
            return True
        time.sleep(0.2)
    return False


# wrk's Lua script: POST the file named by WRK_BODY as text/plain, and at
# the end one JSON line, prefixed "WRK ", with what the section needs.
WRK_LUA = r'''
local f = assert(io.open(os.getenv("WRK_BODY"), "rb"))
wrk.method = "POST"
wrk.body = f:read("*a")
f:close()
wrk.headers["Content-Type"] = "text/plain"

done = function(summary, latency, requests)
    local e = summary.errors
    io.write(string.format('WRK {"requests": %d, "duration_us": %d, "p50_us": %d, "p99_us": %d, ' ..
        '"max_us": %d, "connect": %d, "read": %d, "write": %d, "status": %d, "timeout": %d}\n',
        summary.requests, summary.duration, latency:percentile(50), latency:percentile(99), latency.max,
        e.connect, e.read, e.write, e.status, e.timeout))
end
'''


def wrk(work, url, body_path, connections, seconds):
    """One bounded wrk run (-t2, or -t1 for one connection: wrk needs
    connections >= threads): {requests, rps, p50_ms, p99_ms, max_ms, failed}
    where failed counts non-2xx answers, timeouts and socket errors."""
    lua = os.path.join(work, "post.lua")
    if not os.path.exists(lua):
        with open(lua, "w") as f:
            f.write(WRK_LUA)
    threads = 2 if connections >= 2 else 1
    env = dict(os.environ, WRK_BODY=body_path)
    r = run(["wrk", "-t%d" % threads, "-c%d" % connections, "-d%ds" % seconds, "--latency", "--timeout", "30s",
             "-s", lua, url], env=env, timeout=seconds + 60, what="wrk")
    line = [x for x in r.stdout.splitlines() if x.startswith("WRK ")]
    if not line:
        raise Failed("no WRK line from wrk's Lua script:\n  %s" % "\n  ".join(r.tail()))
    w = json.loads(line[-1][4:])
    return {"connections": connections, "threads": threads, "seconds": seconds, "requests": w["requests"],
            "rps": w["requests"] / w["duration_us"] * 1e6 if w["duration_us"] > 0 else 0.0,
            "p50_ms": w["p50_us"] / 1000.0, "p99_ms": w["p99_us"] / 1000.0, "max_ms": w["max_us"] / 1000.0,
            "failed": sum(w[k] for k in ("connect", "read", "write", "status", "timeout"))}


def hey_csv(text):
    """hey -o csv: [(seconds, status, offset s)] of the answered requests.
    Columns: response-time, DNS+dialup, DNS, request-write, response-delay,
    response-read, status-code, offset."""
    rows = []
    for rec in csv.reader(text.splitlines()[1:]):
        if len(rec) >= 8:
            try:
                rows.append((float(rec[0]), int(rec[6]), float(rec[7])))
            except ValueError:
                continue
    return rows


def percentile(values, p):
    """Nearest-rank percentile, None for no values."""
    v = sorted(values)
    if not v:
        return None
    k = p / 100.0 * len(v)
    i = int(k)
    if i < k:
        i += 1
    return v[min(max(i, 1), len(v)) - 1]


def best(values, pick=min):
    """The best of some runs' figures (min, or pick), ignoring None."""
    values = [v for v in values if v is not None]
    return pick(values) if values else None


def loadavg():
    return list(os.getloadavg())
