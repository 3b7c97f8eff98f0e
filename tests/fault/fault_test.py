#!/usr/bin/env python3
"""Fault test of `rayd serve`: hostile clients for a bounded time while a probe
keeps rendering. The daemon must answer every probe, never die, answer each
kind of bad input as docs/http-api.md says, give its memory and file
descriptors back once the load stops, and exit 0 on SIGTERM within its drain
time. See tests/fault/README.md for what is sent and why each bound is what
it is.

Usage, from the repository root:

    RAYD=build/rayd python3 tests/fault/fault_test.py [--no-new-flags] [--skip GROUP,...] [--seed N] [--keep]

Environment: RAYD (the binary, default build/rayd), FAULT_SECONDS (length of
the load, default 40). Output: one PASS or FAIL line per check, then the line
`fault: N passed, M failed`; the exit status is 1 when anything failed.
Python 3 standard library only.
"""
import argparse
import json
import os
import random
import re
import select
import shutil
import signal
import socket
import statistics
import struct
import subprocess
import sys
import tempfile
import threading
import time
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HOST = "127.0.0.1"

# The daemon's settings; every bound below is derived from them.
JOB_TIMEOUT_MS = 3000
DRAIN_MS = 2000
THREADS = 2
HEADER_TIMEOUT_MS = 2000
BODY_TIMEOUT_MS = 4000
CONNECTION_TIMEOUT_S = 5
MEMORY_BUDGET = 1 << 30
NEW_FLAGS = ("--header-timeout-ms", "--body-timeout-ms", "--memory-budget")

# After the load: RSS may exceed its start by this much (see the README).
RSS_SLACK = 64 << 20
RSS_FACTOR = 1.5
FD_SLACK = 2
SETTLE_S = 15.0

GROUPS = ("nameless", "forms", "bomb", "runaway", "slow", "halfclose", "raw", "args")

# ---------------------------------------------------------------------------
# Inputs

# Grade forms (boundary XyZ) whose only part has no field name as
# libmicrohttpd 0.9.75 sees it: no Content-Disposition, no part headers at
# all, and name=image without quotes. Each must get a 400 JSON error.
FORM_NO_DISPOSITION = b"--XyZ\r\nContent-Type: text/plain\r\n\r\nhello\r\n--XyZ--\r\n"
FORM_NO_HEADERS = b"--XyZ\r\n\r\nhello\r\n--XyZ--\r\n"
FORM_UNQUOTED_NAME = b"--XyZ\r\nContent-Disposition: form-data; name=image\r\n\r\nhello\r\n--XyZ--\r\n"

# A scene no per-row or per-tile check can stop in time: 16x2 pixels, 65536
# samples per pixel, four area lights of 64 samples each (tens of seconds per
# pixel). Only checks inside a pixel's sample loop end it on time.
RUNAWAY_CFG = b"""[render]
width = 16
height = 2
samples = 65536
[camera]
eye = 0 2 6
target = 0 0.5 0
[light panel]
type = area
corner = -1 6 -1
edge1 = 2 0 0
edge2 = 0 0 2
samples = 64
color = 1 1 1
[light a0]
type = area
corner = -2 6 -1
edge1 = 2 0 0
edge2 = 0 0 2
samples = 64
color = 0.2 0.2 0.2
[light a1]
type = area
corner = -1 6 -1
edge1 = 2 0 0
edge2 = 0 0 2
samples = 64
color = 0.2 0.2 0.2
[light a2]
type = area
corner = 0 6 -1
edge1 = 2 0 0
edge2 = 0 0 2
samples = 64
color = 0.2 0.2 0.2
[light a3]
type = area
corner = 1 6 -1
edge1 = 2 0 0
edge2 = 0 0 2
samples = 64
color = 0.2 0.2 0.2
[material m]
type = diffuse
kd = 0.7 0.7 0.7
[sphere]
center = 0 0.8 0
radius = 0.8
material = m
[plane]
point = 0 0 0
normal = 0 1 0
material = m
"""

PNG_SIG = b"\x89PNG\r\n\x1a\n"


def png_chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_rgb(w, h, rgb=(0, 0, 0)):
    """A valid 8-bit RGB PNG of one colour."""
    raw = (b"\x00" + bytes(rgb) * w) * h
    return (PNG_SIG + png_chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + png_chunk(b"IDAT", zlib.compress(raw)) + png_chunk(b"IEND", b""))


# 44 bytes: a valid 320x240 IHDR (the size of the phong assignment), then a
# chunk header declaring tEXt of 2^31-1 bytes, then the file ends. A decoder
# that trusts the length allocates 2 GB before it finds the file short.
PNG_BOMB = (PNG_SIG + png_chunk(b"IHDR", struct.pack(">IIBBBBB", 320, 240, 8, 2, 0, 0, 0))
            + struct.pack(">I", 0x7FFFFFFF) + b"tEXt" + b"abc")


def part(headers, data):
    return headers, data


def multipart(parts, boundary=b"XyZ"):
    out = b""
    for headers, data in parts:
        out += b"--" + boundary + b"\r\n" + b"".join(h + b"\r\n" for h in headers) + b"\r\n" + data + b"\r\n"
    return out + b"--" + boundary + b"--\r\n"


def text_field(name, value):
    return part([b'Content-Disposition: form-data; name="' + name + b'"'], value)


def file_field(name, filename, ctype, data):
    return part([b'Content-Disposition: form-data; name="' + name + b'"; filename="' + filename + b'"',
                 b"Content-Type: " + ctype], data)


def grade_form(image, assignment=b"phong", boundary=b"XyZ"):
    return multipart([text_field(b"assignment", assignment),
                      file_field(b"image", b"mine.png", b"image/png", image)], boundary)


# ---------------------------------------------------------------------------
# HTTP over plain sockets, so that "no answer" and "closed" can be told apart


class Counter:
    def __init__(self):
        self.lock = threading.Lock()
        self.by_group = {}

    def add(self, group, n=1):
        with self.lock:
            self.by_group[group] = self.by_group.get(group, 0) + n

    def total(self):
        with self.lock:
            return sum(self.by_group.values())


REQUESTS = Counter()


class Answer:
    def __init__(self, outcome, status=None, headers=None, body=b"", elapsed=0.0, error=""):
        self.outcome = outcome          # answer, closed, reset, timeout, refused
        self.status = status
        self.headers = headers or {}
        self.body = body
        self.elapsed = elapsed
        self.error = error

    def json(self):
        try:
            return json.loads(self.body)
        except ValueError:
            return None

    def error_code(self):
        """The `error.code` of a JSON error answer, or None."""
        if "json" not in self.headers.get("content-type", ""):
            return None
        o = self.json()
        if isinstance(o, dict) and isinstance(o.get("error"), dict):
            return str(o["error"].get("code"))
        return None

    def is_png(self):
        return (self.status == 200 and self.headers.get("content-type", "").startswith("image/png")
                and self.body.startswith(PNG_SIG))

    def describe(self):
        if self.outcome == "answer":
            code = self.error_code()
            if code:
                return "%d %s" % (self.status, code)
            return "%d %s" % (self.status, self.headers.get("content-type", "(no type)"))
        return {"closed": "closed without an answer", "reset": "reset without an answer",
                "timeout": "no answer in %.1f s" % self.elapsed,
                "refused": "connect failed (%s)" % self.error}.get(self.outcome, self.outcome)


def http_request(method, target, body=None, ctype=None, headers=()):
    lines = ["%s %s HTTP/1.1" % (method, target), "Host: " + HOST, "Connection: close"]
    if ctype:
        lines.append("Content-Type: " + ctype)
    if body is not None:
        lines.append("Content-Length: %d" % len(body))
    lines += list(headers)
    return ("\r\n".join(lines) + "\r\n\r\n").encode("latin-1") + (body or b"")


def _recv(sock, deadline):
    left = deadline - time.monotonic()
    if left <= 0:
        raise socket.timeout()
    sock.settimeout(left)
    return sock.recv(65536)


def read_answer(sock, t0, deadline):
    """The final answer: interim 1xx answers (100 Continue, 102 Processing)
    are skipped, as HTTP/1.1 clients must."""
    buf = b""
    while True:
        while b"\r\n\r\n" not in buf:
            chunk = _recv(sock, deadline)
            if not chunk:
                return Answer("closed", elapsed=time.monotonic() - t0, body=buf)
            buf += chunk
        head, body = buf.split(b"\r\n\r\n", 1)
        lines = head.decode("latin-1").split("\r\n")
        try:
            status = int(lines[0].split()[1])
        except (IndexError, ValueError):
            return Answer("closed", elapsed=time.monotonic() - t0, body=buf, error="bad status line")
        if 100 <= status < 200 and status != 101:
            buf = body
            continue
        break
    headers = {}
    for line in lines[1:]:
        k, _, v = line.partition(":")
        headers[k.strip().lower()] = v.strip()
    if "content-length" in headers:
        need = int(headers["content-length"])
        while len(body) < need:
            chunk = _recv(sock, deadline)
            if not chunk:
                break
            body += chunk
    elif "chunked" in headers.get("transfer-encoding", "").lower():
        raw, body = body, b""
        while True:
            while b"\r\n" not in raw:
                chunk = _recv(sock, deadline)
                if not chunk:
                    break
                raw += chunk
            size_line, _, raw = raw.partition(b"\r\n")
            size = int(size_line.split(b";")[0] or b"0", 16)
            while len(raw) < size + 2:
                chunk = _recv(sock, deadline)
                if not chunk:
                    break
                raw += chunk
            if size == 0:
                break
            body += raw[:size]
            raw = raw[size + 2:]
    else:
        while True:
            chunk = _recv(sock, deadline)
            if not chunk:
                break
            body += chunk
    return Answer("answer", status, headers, body, time.monotonic() - t0)


def exchange(port, data, group, timeout=10.0, shut_wr=False):
    """Send one request on a new connection and read its answer."""
    REQUESTS.add(group)
    t0 = time.monotonic()
    deadline = t0 + timeout
    try:
        sock = socket.create_connection((HOST, port), timeout=timeout)
    except OSError as e:
        return Answer("refused", elapsed=time.monotonic() - t0, error=e.strerror or str(e))
    with sock:
        try:
            sock.sendall(data)
            if shut_wr:
                sock.shutdown(socket.SHUT_WR)
        except socket.timeout:
            return Answer("timeout", elapsed=time.monotonic() - t0)
        except OSError:
            pass  # the server may answer before it has read everything
        try:
            return read_answer(sock, t0, deadline)
        except socket.timeout:
            return Answer("timeout", elapsed=time.monotonic() - t0)
        except ConnectionResetError:
            return Answer("reset", elapsed=time.monotonic() - t0)
        except OSError as e:
            return Answer("reset", elapsed=time.monotonic() - t0, error=str(e))


def get_json(port, path, group, timeout=5.0):
    a = exchange(port, http_request("GET", path), group, timeout)
    return a, (a.json() if a.outcome == "answer" else None)


# ---------------------------------------------------------------------------
# Results


class Report:
    def __init__(self):
        self.passed = 0
        self.failed = 0
        self.lock = threading.Lock()

    def check(self, name, ok, detail):
        with self.lock:
            if ok:
                self.passed += 1
            else:
                self.failed += 1
            print("%s %s: %s" % ("PASS" if ok else "FAIL", name, detail), flush=True)
        return ok

    def note(self, text):
        with self.lock:
            print("  " + text, flush=True)


class Tally:
    """Outcomes of many requests of one kind."""

    def __init__(self, name, expect):
        self.name = name
        self.expect = expect  # human-readable
        self.n = 0
        self.ok = 0
        self.outcomes = {}
        self.worst = 0.0

    def add(self, ok, outcome, elapsed=0.0):
        self.n += 1
        self.ok += 1 if ok else 0
        self.outcomes[outcome] = self.outcomes.get(outcome, 0) + 1
        self.worst = max(self.worst, elapsed)

    def detail(self):
        seen = ", ".join("%d x %s" % (c, o) for o, c in sorted(self.outcomes.items(), key=lambda x: -x[1]))
        if not self.n:
            return "none sent before the load stopped"
        return "%d/%d %s (%s; slowest %.2f s)" % (self.ok, self.n, self.expect, seen, self.worst)

    def report(self, rep):
        rep.check(self.name, self.n > 0 and self.ok == self.n, self.detail())


def describe_rc(rc):
    if rc is None:
        return "still running"
    if rc < 0:
        try:
            return "killed by signal %d (%s)" % (-rc, signal.Signals(-rc).name)
        except ValueError:
            return "killed by signal %d" % -rc
    return "exit status %d" % rc


def pct(values, p):
    v = sorted(values)
    return v[max(0, min(len(v) - 1, int(round(p * len(v) + 0.5)) - 1))]


def mb(n):
    return "%.1f MB" % (n / 1e6) if n is not None else "?"


# ---------------------------------------------------------------------------
# The daemon


class StartError(Exception):
    pass


class Daemon:
    def __init__(self, rayd, workdir, new_flags):
        self.port_file = os.path.join(workdir, "port")
        self.log_path = os.path.join(workdir, "rayd.log")
        self.args = [rayd, "serve", "--listen", HOST + ":0", "--port-file", self.port_file,
                     "--scenes", os.path.join(ROOT, "scenes"),
                     "--assignments", os.path.join(ROOT, "scenes", "assignments"),
                     "--job-timeout-ms", str(JOB_TIMEOUT_MS), "--drain-ms", str(DRAIN_MS),
                     "--threads", str(THREADS), "--data-dir", os.path.join(workdir, "var")]
        if new_flags:
            self.args += ["--header-timeout-ms", str(HEADER_TIMEOUT_MS), "--body-timeout-ms", str(BODY_TIMEOUT_MS)]
        self.args += ["--connection-timeout", str(CONNECTION_TIMEOUT_S)]
        if new_flags:
            self.args += ["--memory-budget", str(MEMORY_BUDGET)]
        self.proc = None
        self.port = None
        self.dead = threading.Event()
        self.died_at = None
        self.rc = None
        self.peak_rss = 0
        self.peak_fds = 0
        self.on_death = None
        self._stop_monitor = threading.Event()
        self._monitor = None

    def start(self):
        log = open(self.log_path, "wb")
        try:
            self.proc = subprocess.Popen(self.args, stdin=subprocess.DEVNULL, stdout=log, stderr=log, cwd=ROOT)
        except OSError as e:
            raise StartError("cannot run %s: %s" % (self.args[0], e))
        finally:
            log.close()
        end = time.monotonic() + 10
        while time.monotonic() < end:
            rc = self.proc.poll()
            if rc is not None:
                text = self.log_tail(20)
                m = re.search(r"unknown option '([^']+)'", text)
                if m:
                    extra = ""
                    if m.group(1) in NEW_FLAGS:
                        extra = (" (this binary predates %s; rebuild it, or pass --no-new-flags to test it"
                                 " without them)" % ", ".join(NEW_FLAGS))
                    raise StartError("`rayd serve` refused the option %s%s" % (m.group(1), extra))
                raise StartError("`rayd serve` exited at start, %s:\n%s" % (describe_rc(rc), text))
            try:
                with open(self.port_file) as f:
                    text = f.read().strip()
                if text:
                    self.port = int(text)
                    return self.port
            except (OSError, ValueError):
                pass
            time.sleep(0.05)
        self.kill()
        raise StartError("`rayd serve` wrote no port file in 10 s")

    @property
    def pid(self):
        return self.proc.pid

    def alive(self):
        return not self.dead.is_set() and self.proc.poll() is None

    def rss(self):
        try:
            with open("/proc/%d/status" % self.pid) as f:
                for line in f:
                    if line.startswith("VmRSS:"):
                        return int(line.split()[1]) * 1024
        except OSError:
            pass
        return None

    def hwm(self):
        try:
            with open("/proc/%d/status" % self.pid) as f:
                for line in f:
                    if line.startswith("VmHWM:"):
                        return int(line.split()[1]) * 1024
        except OSError:
            pass
        return None

    def fds(self):
        try:
            return len(os.listdir("/proc/%d/fd" % self.pid))
        except OSError:
            return None

    def start_monitor(self, t0):
        def run():
            last = 0.0
            while not self._stop_monitor.is_set():
                rc = self.proc.poll()
                if rc is not None:
                    self.rc = rc
                    self.died_at = time.monotonic() - t0
                    self.dead.set()
                    print("  the daemon died %.1f s into the load: %s" % (self.died_at, describe_rc(rc)), flush=True)
                    if self.on_death:
                        self.on_death()
                    return
                now = time.monotonic()
                if now - last >= 0.25:
                    last = now
                    r, n = self.rss(), self.fds()
                    if r:
                        self.peak_rss = max(self.peak_rss, r)
                    if n:
                        self.peak_fds = max(self.peak_fds, n)
                self._stop_monitor.wait(0.1)

        self._monitor = threading.Thread(target=run, daemon=True)
        self._monitor.start()

    def stop_monitor(self):
        self._stop_monitor.set()
        if self._monitor:
            self._monitor.join()

    def log_offset(self):
        try:
            return os.path.getsize(self.log_path)
        except OSError:
            return 0

    def log_since(self, offset):
        try:
            with open(self.log_path, "rb") as f:
                f.seek(offset)
                return f.read().decode("utf-8", "replace")
        except OSError:
            return ""

    def log_tail(self, n):
        try:
            with open(self.log_path, "rb") as f:
                return "\n".join(f.read().decode("utf-8", "replace").splitlines()[-n:])
        except OSError:
            return ""

    def kill(self):
        if self.proc and self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGKILL)
            self.proc.wait()


# ---------------------------------------------------------------------------
# The load: one thread per kind of client, each with a request cap, all
# stopping at the deadline or as soon as the daemon dies.


class Load:
    def __init__(self, daemon, seconds, seed, skip):
        self.d = daemon
        self.port = daemon.port
        self.seconds = seconds
        self.skip = skip
        self.rng_seed = seed
        self.stop = threading.Event()
        self.t0 = None
        self.deadline = None
        self.caps = {}
        self.phong = open(os.path.join(ROOT, "scenes", "phong.cfg"), "rb").read()
        self.probe_req = http_request("POST", "/v1/render?width=64&height=64", self.phong, "text/plain")
        self.probes = []            # (t, Answer)
        self.forms = {}             # label -> Tally
        self.bombs = Tally("PNG bomb (a 2^31-1 byte chunk) as a grade image", "answered 4xx")
        self.runaway = {}           # check name -> [(ok, detail)]
        self.slow = {"slowloris": [], "slowbody": []}   # [(closed_after or None, first answer line)]
        self.halfclose = Tally("half-closed client (full render request, then shutdown(SHUT_WR))",
                               "answered 200 PNG")
        self.raw = Tally("random bytes on raw sockets", "answered without a 500, or closed")
        self.args = Tally("600 query arguments", "answered 400, 414 or 431")
        self.notes = []
        self.errors = []
        for group, label, _, (expect, _) in self.form_kinds(random.Random(0))[0]:
            if group not in skip:
                self.forms[label] = Tally(label, expect)

    # -- helpers

    def running(self):
        return not self.stop.is_set() and time.monotonic() < self.deadline

    def left(self):
        return self.deadline - time.monotonic()

    def sleep(self, s):
        self.stop.wait(max(0.0, s))

    def at(self, t):
        """Sleep until t seconds into the load."""
        self.sleep(self.t0 + t - time.monotonic())

    # -- probe

    def probe_loop(self):
        cap = int(self.seconds) + 2
        self.caps["probe"] = cap
        for _ in range(cap):
            if not self.running():
                break
            t = time.monotonic()
            a = exchange(self.port, self.probe_req, "probe", timeout=10.0)
            self.probes.append((t - self.t0, a))
            self.sleep(t + 1.0 - time.monotonic())

    # -- grade forms

    def form_kinds(self, rng):
        good = png_rgb(320, 240)

        def truncated():
            body = grade_form(good)
            # Cut before the end of the PNG's IDAT, so no cut leaves a whole image.
            return body[:rng.randrange(20, len(body) - 40)]

        def random_form():
            if rng.random() < 0.5:
                return rng.randbytes(rng.randrange(16, 4096))
            pieces = []
            for _ in range(rng.randrange(1, 6)):
                pieces.append(b"--XyZ\r\n" + rng.randbytes(rng.randrange(0, 300)) + b"\r\n\r\n"
                              + rng.randbytes(rng.randrange(0, 600)) + b"\r\n")
            return b"".join(pieces) + (b"--XyZ--\r\n" if rng.random() < 0.5 else b"")

        # libmicrohttpd reads one level of multipart/mixed inside a form
        # part (a valid PNG in there is graded); these two are not valid:
        # the inner file is not a PNG, or the nested part has no boundary.
        inner = multipart([file_field(b"image", b"a.png", b"image/png", b"hello")], b"InNeR")[:-2]
        nested = multipart([
            text_field(b"assignment", b"phong"),
            part([b'Content-Disposition: form-data; name="image"', b"Content-Type: multipart/mixed; boundary=InNeR"],
                 inner),
        ])
        nested_nb = multipart([
            text_field(b"assignment", b"phong"),
            part([b'Content-Disposition: form-data; name="image"', b"Content-Type: multipart/mixed"], inner),
        ])
        ct = "multipart/form-data; boundary=XyZ"
        bad400 = ("answered 400 JSON error", lambda a: a.status == 400 and a.error_code() is not None)
        any4xx = ("answered 4xx JSON error", lambda a: a.status and 400 <= a.status < 500 and a.error_code() is not None)
        size = ("answered 422 size_mismatch", lambda a: a.status == 422 and a.error_code() == "size_mismatch")
        # "nameless": parts that have (or, for random bytes, may have) no
        # field name as libmicrohttpd sees it.
        return [
            ("nameless", "grade form, part without Content-Disposition", lambda: FORM_NO_DISPOSITION, bad400),
            ("nameless", "grade form, part without headers", lambda: FORM_NO_HEADERS, bad400),
            ("nameless", "grade form, unquoted name=image", lambda: FORM_UNQUOTED_NAME, bad400),
            ("nameless", "grade form, random bytes", random_form, any4xx),
            ("forms", "grade form, truncated", truncated, any4xx),
            ("forms", "grade form, 64x48 PNG for a 320x240 assignment", lambda: grade_form(png_rgb(64, 48)), size),
            ("forms", "grade form, assignment of 200 bytes", lambda: grade_form(good, b"a" * 200), any4xx),
            ("forms", "grade form, nested multipart/mixed part holding a non-PNG", lambda: nested, any4xx),
            ("forms", "grade form, nested multipart/mixed part without a boundary", lambda: nested_nb, any4xx),
        ], ct

    def form_loop(self, group, seed, cap):
        rng = random.Random(seed)
        kinds, ct = self.form_kinds(rng)
        kinds = [k for k in kinds if k[0] == group]
        self.caps[group] = cap
        for i in range(cap):
            if not self.running():
                break
            _, label, build, (_, ok) = kinds[i % len(kinds)]
            body = build()
            a = exchange(self.port, http_request("POST", "/v1/grade", body, ct), group, timeout=8.0)
            self.forms[label].add(bool(ok(a)), a.describe(), a.elapsed)
            self.sleep(0.2)

    def nameless_loop(self):
        self.form_loop("nameless", self.rng_seed, 120)

    def forms_loop(self):
        self.form_loop("forms", self.rng_seed + 2, 120)

    # -- PNG bomb

    def bomb_loop(self):
        cap = 4
        self.caps["bomb"] = cap
        form = grade_form(PNG_BOMB)
        req = http_request("POST", "/v1/grade", form, "multipart/form-data; boundary=XyZ")
        self.at(2.0)
        for _ in range(cap):
            if not self.running():
                break
            t = time.monotonic()
            a = exchange(self.port, req, "bomb", timeout=10.0)
            self.bombs.add(a.status is not None and 400 <= a.status < 500, a.describe(), a.elapsed)
            self.sleep(t + 8.0 - time.monotonic())

    # -- runaway scenes

    def _rw(self, name, ok, detail):
        self.runaway.setdefault(name, []).append((ok, detail))

    def _submit_runaway(self):
        a = exchange(self.port, http_request("POST", "/v1/jobs", RUNAWAY_CFG, "text/plain"), "runaway", 5.0)
        o = a.json() if a.outcome == "answer" else None
        if a.status != 202 or not isinstance(o, dict) or "id" not in o:
            return None, a
        return o["id"], a

    def _job(self, jid):
        _, o = get_json(self.port, "/v1/jobs/" + jid, "runaway", 3.0)
        return o if isinstance(o, dict) else {}

    def runaway_delete(self):
        name = "DELETE of a running runaway job: status cancelled within 1 s"
        jid, a = self._submit_runaway()
        if not jid:
            self._rw(name, False, "POST /v1/jobs: " + a.describe())
            return
        self.sleep(0.5)
        d = exchange(self.port, http_request("DELETE", "/v1/jobs/" + jid), "runaway", 3.0)
        t = time.monotonic()
        if d.status != 200:
            self._rw(name, False, "DELETE answered " + d.describe())
            return
        status = (d.json() or {}).get("status")
        while status != "cancelled" and time.monotonic() - t < 1.0 and not self.d.dead.is_set():
            time.sleep(0.1)
            status = self._job(jid).get("status")
        took = time.monotonic() - t
        if status == "cancelled":
            self._rw(name, True, "cancelled %.2f s after the DELETE" % took)
        else:
            self._rw(name, False, "status still %s %.1f s after the DELETE" % (status, took))

    def runaway_timeout(self):
        name = "runaway job left alone: failed on the time limit within job-timeout + 1 s"
        limit = JOB_TIMEOUT_MS / 1000 + 1.0
        t = time.monotonic()
        jid, a = self._submit_runaway()
        if not jid:
            self._rw(name, False, "POST /v1/jobs: " + a.describe())
            return
        o = {}
        while not self.d.dead.is_set():
            o = self._job(jid)
            # Time spent queued does not count, up to 3 s of it.
            queued = min(3.0, float(o.get("queued_ms") or 0) / 1000)
            if o.get("status") in ("done", "failed", "cancelled") or time.monotonic() - t > limit + queued:
                break
            time.sleep(0.2)
        took = time.monotonic() - t
        err = o.get("error") if isinstance(o.get("error"), dict) else {}
        text = "%s %s" % (err.get("code", ""), err.get("message", ""))
        on_limit = err.get("code") == "time_limit" or "job-timeout" in text or "time limit" in text
        if o.get("status") == "failed" and on_limit:
            self._rw(name, True, "failed after %.1f s: %s" % (took, text.strip()))
        else:
            self._rw(name, False, "status %s after %.1f s (limit %.1f s)%s"
                     % (o.get("status"), took, limit, ": " + text.strip() if text.strip() else ""))
            if o.get("status") in ("queued", "running"):
                exchange(self.port, http_request("DELETE", "/v1/jobs/" + jid), "runaway", 3.0)

    def runaway_hangup(self):
        name = "synchronous runaway render, client gone after 1 s: job cancelled within 2 s"
        offset = self.d.log_offset()
        REQUESTS.add("runaway")
        try:
            sock = socket.create_connection((HOST, self.port), timeout=3)
        except OSError as e:
            self._rw(name, False, "connect failed: %s" % e)
            return
        answered = None
        with sock:
            sock.sendall(http_request("POST", "/v1/render", RUNAWAY_CFG, "text/plain"))
            r, _, _ = select.select([sock], [], [], 1.0)
            if r:
                try:
                    answered = sock.recv(200).split(b"\r\n", 1)[0].decode("latin-1", "replace")
                except OSError:
                    answered = "(reset)"
        t = time.monotonic()
        if answered is not None:
            self.notes.append("the synchronous runaway render was answered before its client left (%s);"
                              " not counted" % (answered or "closed"))
            return
        pat = re.compile(r"POST /v1/render\S* \S+ \S+ \S+ id=\S+ job=([0-9a-f]+) .*\(connection closed early\)")
        checked = set()
        last = "no log line says a /v1/render connection closed early"
        while time.monotonic() - t < 2.0 and not self.d.dead.is_set():
            for jid in pat.findall(self.d.log_since(offset)):
                if jid in checked:
                    continue
                o = self._job(jid)
                if o.get("width") != 16 or o.get("height") != 2:
                    checked.add(jid)
                    continue
                if o.get("status") == "cancelled":
                    self._rw(name, True, "job %s cancelled %.2f s after the hang-up" % (jid, time.monotonic() - t))
                    return
                last = "job %s is %s" % (jid, o.get("status"))
            time.sleep(0.2)
        self._rw(name, False, "%s %.1f s after the hang-up" % (last, time.monotonic() - t))

    def runaway_loop(self):
        cycles = 3
        # At most 13 requests for the DELETE case, 38 for the timeout case
        # (a status poll every 0.2 s) and about 15 for the hang-up case.
        self.caps["runaway"] = cycles * 70
        self.at(1.0)
        for _ in range(cycles):
            # A cycle takes about 7 s, 14 s at worst; one runaway job at a
            # time leaves a render thread for everyone else.
            if not self.running() or self.left() < 14.0:
                break
            self.runaway_delete()
            self.runaway_timeout()
            self.runaway_hangup()
            self.sleep(1.0)

    # -- slow clients

    def slow_wave(self, n_loris, n_body):
        conns = []
        loris_head = ("GET /healthz HTTP/1.1\r\nHost: %s\r\n" % HOST).encode()
        body_head = http_request("POST", "/v1/render?width=16&height=16", None, "text/plain",
                                 ["Content-Length: %d" % len(self.phong)])
        for i in range(n_loris + n_body):
            kind = "slowloris" if i < n_loris else "slowbody"
            REQUESTS.add("slow")
            try:
                s = socket.create_connection((HOST, self.port), timeout=3)
            except OSError as e:
                self.slow[kind].append((None, "connect failed: %s" % e))
                continue
            c = {"kind": kind, "sock": s, "t": time.monotonic(), "pos": 0, "closed": None, "first": ""}
            try:
                if kind == "slowloris":
                    s.sendall(loris_head)
                    c["trickle"] = b"X-Slow: " + b"a" * 100
                    c["limit"] = HEADER_TIMEOUT_MS / 1000 + 2.0
                else:
                    s.sendall(body_head)
                    c["t"] = time.monotonic()  # the body deadline counts from the end of the header
                    c["trickle"] = self.phong
                    c["limit"] = BODY_TIMEOUT_MS / 1000 + 2.0
            except OSError:
                c["closed"] = 0.0
            conns.append(c)
        window = max(c["limit"] for c in conns) + 6.0 if conns else 0
        end = time.monotonic() + window
        tick = time.monotonic() + 1.0
        while time.monotonic() < end and not self.d.dead.is_set():
            live = [c for c in conns if c["closed"] is None]
            if not live:
                break
            r, _, _ = select.select([c["sock"] for c in live], [], [], max(0.0, min(tick, end) - time.monotonic()))
            now = time.monotonic()
            for c in live:
                if c["sock"] in r:
                    try:
                        data = c["sock"].recv(4096)
                    except OSError:
                        data = b""
                    if not data:
                        c["closed"] = now - c["t"]
                    elif not c["first"]:
                        c["first"] = data.split(b"\r\n", 1)[0].decode("latin-1", "replace")
            if now >= tick:
                tick += 1.0
                for c in live:
                    if c["closed"] is None:
                        try:
                            c["sock"].send(c["trickle"][c["pos"]:c["pos"] + 1])
                            c["pos"] = (c["pos"] + 1) % len(c["trickle"])
                        except OSError:
                            c["closed"] = now - c["t"]
        for c in conns:
            c["sock"].close()
            self.slow[c["kind"]].append((c["closed"], c["first"]))

    def slow_loop(self):
        waves = 2
        self.caps["slow"] = waves * 25
        self.at(0.5)
        for w in range(waves):
            if not self.running() or self.left() < 13.0:
                break
            self.slow_wave(20, 5)
            self.at(15.0 * (w + 1))

    # -- half-close

    def halfclose_loop(self):
        cap = 6
        self.caps["halfclose"] = cap
        req = http_request("POST", "/v1/render?width=256&height=256", self.phong, "text/plain")
        self.at(1.5)
        for _ in range(cap):
            if not self.running():
                break
            t = time.monotonic()
            a = exchange(self.port, req, "halfclose", timeout=10.0, shut_wr=True)
            self.halfclose.add(a.is_png(), a.describe() if not a.is_png() else "200 PNG", a.elapsed)
            self.sleep(t + 5.0 - time.monotonic())

    # -- random bytes

    def raw_loop(self):
        rng = random.Random(self.rng_seed + 1)
        cap = 120
        self.caps["raw"] = cap
        for _ in range(cap):
            if not self.running():
                break
            data = rng.randbytes(rng.randrange(1, 2048))
            REQUESTS.add("raw")
            t = time.monotonic()
            try:
                s = socket.create_connection((HOST, self.port), timeout=3)
            except OSError as e:
                self.raw.add(False, "connect failed (%s)" % (e.strerror or e))
                self.sleep(0.25)
                continue
            got = b""
            outcome = None
            with s:
                try:
                    s.sendall(data)
                    end = t + 3.0
                    while True:
                        chunk = _recv(s, end)
                        if not chunk:
                            break
                        got += chunk
                except socket.timeout:
                    outcome = "no answer in 3 s"
                except OSError:
                    outcome = "reset"
            if got.startswith(b"HTTP/"):
                try:
                    code = int(got.split(None, 2)[1])
                except (IndexError, ValueError):
                    code = 0
                self.raw.add(code != 500, "answered %d" % code, time.monotonic() - t)
            else:
                self.raw.add(True, outcome or "closed without an answer", time.monotonic() - t)
            self.sleep(0.25)

    # -- many query arguments

    def args_loop(self):
        cap = 8
        self.caps["args"] = cap
        query = "&".join("a%d=%d" % (i, i) for i in range(600))
        req = http_request("GET", "/healthz?" + query)
        self.at(3.0)
        for _ in range(cap):
            if not self.running():
                break
            t = time.monotonic()
            a = exchange(self.port, req, "args", timeout=CONNECTION_TIMEOUT_S + 3.0)
            self.args.add(a.status in (400, 414, 431), a.describe(), a.elapsed)
            self.sleep(t + 4.0 - time.monotonic())

    # -- run

    def run(self):
        self.t0 = time.monotonic()
        self.deadline = self.t0 + self.seconds
        self.d.on_death = self.stop.set
        self.d.start_monitor(self.t0)
        def guarded(name, fn):
            def run():
                try:
                    fn()
                except Exception as e:  # a harness bug, not a daemon fault: reported as a failed check
                    self.errors.append("%s: %s: %s" % (name, type(e).__name__, e))
            return threading.Thread(target=run, name=name, daemon=True)

        threads = [guarded("probe", self.probe_loop)]
        for g in GROUPS:
            if g not in self.skip:
                threads.append(guarded(g, getattr(self, g + "_loop")))
        for t in threads:
            t.start()
        self.stop.wait(self.seconds)
        self.stop.set()
        # Every socket operation has its own timeout (10 s at most).
        end = time.monotonic() + 20
        for t in threads:
            t.join(max(0.1, end - time.monotonic()))
        self.elapsed = time.monotonic() - self.t0
        self.d.stop_monitor()
        return [t.name for t in threads if t.is_alive()]


# ---------------------------------------------------------------------------


def warm_up(d, rep):
    """A few renders, a grade and an async job, so that the starting RSS
    includes the caches and pools normal work fills."""
    port = d.port
    phong = open(os.path.join(ROOT, "scenes", "phong.cfg"), "rb").read()
    problems = []
    for _ in range(3):
        a = exchange(port, http_request("POST", "/v1/render?width=64&height=64", phong, "text/plain"), "warm-up")
        if not a.is_png():
            problems.append("render: " + a.describe())
    a = exchange(port, http_request("POST", "/v1/grade", grade_form(png_rgb(320, 240)),
                                    "multipart/form-data; boundary=XyZ"), "warm-up", 20.0)
    if a.status != 200 or not isinstance(a.json(), dict):
        problems.append("grade of a valid 320x240 PNG: " + a.describe())
    a = exchange(port, http_request("POST", "/v1/jobs?width=32&height=32", phong, "text/plain"), "warm-up")
    o = a.json() if a.outcome == "answer" else None
    if a.status == 202 and isinstance(o, dict) and "id" in o:
        end = time.monotonic() + 5
        status = None
        while time.monotonic() < end:
            _, s = get_json(port, "/v1/jobs/" + o["id"], "warm-up")
            status = (s or {}).get("status")
            if status not in ("queued", "running"):
                break
            time.sleep(0.05)
        img = exchange(port, http_request("GET", "/v1/jobs/%s/image" % o["id"]), "warm-up")
        if status != "done" or not img.is_png():
            problems.append("async job: status %s, image %s" % (status, img.describe()))
    else:
        problems.append("POST /v1/jobs: " + a.describe())
    rep.check("warm-up", not problems and d.alive(),
              "; ".join(problems) if problems else "3 renders, a grade and an async job answered as expected")
    time.sleep(0.5)
    fds = []
    for _ in range(5):
        n = d.fds()
        if n is not None:
            fds.append(n)
        time.sleep(0.2)
    return d.rss(), (min(fds) if fds else None)


def report_load(load, d, rep, skip):
    print("-- load: %.1f s, %d requests (cap %d): %s" % (
        load.elapsed, REQUESTS.total() - REQUESTS.by_group.get("warm-up", 0), sum(load.caps.values()),
        ", ".join("%s %d" % (g, n) for g, n in sorted(REQUESTS.by_group.items()) if g != "warm-up")), flush=True)
    print("-- peak during the load: RSS %s (sampled every 0.25 s), %d open fds" % (
        mb(d.peak_rss), d.peak_fds), flush=True)

    # Probes
    ok = [a for _, a in load.probes if a.is_png()]
    bad = [(t, a) for t, a in load.probes if not a.is_png()]
    lat = [a.elapsed * 1000 for _, a in load.probes if a.outcome == "answer"]
    stats = ("latency ms min/median/p95/max %.1f/%.1f/%.1f/%.1f" % (
        min(lat), statistics.median(lat), pct(lat, 0.95), max(lat))) if lat else "no latency measured"
    detail = "%d/%d answered 200 PNG; %s" % (len(ok), len(load.probes), stats)
    if bad:
        detail += "; failures: " + ", ".join("t=%.1fs %s" % (t, a.describe()) for t, a in bad[:6])
        if len(bad) > 6:
            detail += ", ... (%d in all)" % len(bad)
    if d.dead.is_set():
        detail += "; probing stopped when the daemon died at t=%.1f s" % d.died_at
    for e in load.errors:
        rep.check("client thread ran to its end", False, e)
    rep.check("probe renders (64x64 phong, 1 per second)", bool(load.probes) and not bad and not d.dead.is_set(),
              detail)
    rep.check("daemon alive throughout the load", not d.dead.is_set(),
              "pid %d alive after %.1f s" % (d.pid, load.elapsed) if not d.dead.is_set()
              else "died at t=%.1f s: %s" % (d.died_at, describe_rc(d.rc)))
    hwm = d.hwm()
    rep.check("peak RSS (VmHWM) below --memory-budget", hwm is not None and hwm < MEMORY_BUDGET,
              "VmHWM %s, budget %s" % (mb(hwm), mb(MEMORY_BUDGET)) if hwm is not None
              else "the daemon is not running")

    for tally in load.forms.values():
        tally.report(rep)
    if "bomb" not in skip:
        load.bombs.report(rep)
    if "runaway" not in skip:
        names = ["DELETE of a running runaway job: status cancelled within 1 s",
                 "runaway job left alone: failed on the time limit within job-timeout + 1 s",
                 "synchronous runaway render, client gone after 1 s: job cancelled within 2 s"]
        for name in names:
            results = load.runaway.get(name, [])
            good = sum(1 for okay, _ in results if okay)
            details = "; ".join(dict.fromkeys(det for _, det in results)) or "not run before the load stopped"
            rep.check(name, bool(results) and good == len(results), "%d/%d: %s" % (good, len(results), details))
        for n in load.notes:
            rep.note(n)
    if "slow" not in skip:
        for kind, what, limit in (("slowloris", "slowloris (1 header byte per second)", HEADER_TIMEOUT_MS / 1000 + 2),
                                  ("slowbody", "slow body (1 body byte per second)", BODY_TIMEOUT_MS / 1000 + 2)):
            res = load.slow[kind]
            closed = [c for c, _ in res if c is not None]
            in_time = [c for c in closed if c <= limit]
            answers = {}
            for _, first in res:
                if first:
                    answers[first] = answers.get(first, 0) + 1
            if not res:
                rep.check(what, False, "none sent before the load stopped")
                continue
            detail = "%d/%d closed by the server within %.1f s" % (len(in_time), len(res), limit)
            if closed:
                detail += " (closed after %.1f..%.1f s)" % (min(closed), max(closed))
            if len(closed) < len(res):
                detail += "; %d still open when the client gave up" % (len(res) - len(closed))
            if answers:
                detail += "; answers: " + ", ".join("%d x %s" % (n, a) for a, n in answers.items())
            rep.check(what, bool(res) and len(in_time) == len(res), detail)
    if "halfclose" not in skip:
        load.halfclose.report(rep)
    if "raw" not in skip:
        rep.check(load.raw.name, load.raw.n > 0 and load.raw.ok == load.raw.n and not d.dead.is_set(),
                  load.raw.detail() + ("; the daemon died" if d.dead.is_set() else ""))
    if "args" not in skip:
        load.args.report(rep)


def settle(d, rep, start_rss, start_fds):
    rss_limit = max(start_rss + RSS_SLACK, int(start_rss * RSS_FACTOR)) if start_rss else None
    fd_limit = start_fds + FD_SLACK if start_fds is not None else None
    if not d.alive():
        why = "the daemon is not running (%s)" % describe_rc(d.proc.poll())
        rep.check("RSS back after the load", False, why)
        rep.check("open fds back after the load", False, why)
        return
    t = time.monotonic()
    rss = fds = None
    while True:
        rss, fds = d.rss(), d.fds()
        if rss is not None and fds is not None and rss <= rss_limit and fds <= fd_limit:
            break
        if time.monotonic() - t >= SETTLE_S or not d.alive():
            break
        time.sleep(0.5)
    took = time.monotonic() - t
    rep.check("RSS back after the load", rss is not None and rss <= rss_limit,
              "%s after %.1f s (start %s, limit %s, peak %s)" % (mb(rss), took, mb(start_rss), mb(rss_limit),
                                                                  mb(d.peak_rss)))
    rep.check("open fds back after the load", fds is not None and fds <= fd_limit,
              "%s after %.1f s (start %s, limit %s, peak %d)" % (fds, took, start_fds, fd_limit, d.peak_fds))


def sigterm(d, rep):
    name = "SIGTERM: exit status 0 within drain-ms + 5 s"
    limit = DRAIN_MS / 1000 + 5.0
    rc = d.proc.poll()
    if rc is not None:
        rep.check(name, False, "the daemon had already stopped: %s" % describe_rc(rc))
        return
    t = time.monotonic()
    os.kill(d.pid, signal.SIGTERM)
    try:
        rc = d.proc.wait(timeout=limit)
    except subprocess.TimeoutExpired:
        d.kill()
        rep.check(name, False, "still running %.1f s after SIGTERM; killed with SIGKILL" % limit)
        return
    took = time.monotonic() - t
    rep.check(name, rc == 0, "%s after %.1f s (limit %.1f s)" % (describe_rc(rc), took, limit))


def main():
    ap = argparse.ArgumentParser(description="Bounded fault test of `rayd serve`.")
    ap.add_argument("--no-new-flags", action="store_true",
                    help="start the daemon without %s (for binaries that predate them)" % ", ".join(NEW_FLAGS))
    ap.add_argument("--skip", default="", help="comma-separated client groups not to run: " + ",".join(GROUPS))
    ap.add_argument("--seed", type=int, default=None, help="seed of the random inputs (default: random, printed)")
    ap.add_argument("--keep", action="store_true", help="keep the daemon's log and print where it is")
    opt = ap.parse_args()
    skip = {s for s in opt.skip.split(",") if s}
    unknown = skip - set(GROUPS)
    if unknown:
        ap.error("unknown group(s) in --skip: %s (known: %s)" % (", ".join(sorted(unknown)), ",".join(GROUPS)))
    seconds = float(os.environ.get("FAULT_SECONDS", "40"))
    seed = opt.seed if opt.seed is not None else random.randrange(1 << 30)
    rayd = os.environ.get("RAYD", "build/rayd")
    if not os.path.exists(rayd) and os.path.exists(os.path.join(ROOT, rayd)):
        rayd = os.path.join(ROOT, rayd)
    rayd = os.path.abspath(rayd)

    rep = Report()
    workdir = tempfile.mkdtemp(prefix="rayd-fault-")
    d = Daemon(rayd, workdir, not opt.no_new_flags)
    try:
        try:
            d.start()
        except StartError as e:
            rep.check("start", False, str(e))
            return 1
        print("-- rayd serve on %s:%d, pid %d, %s; load %.0f s, seed %d%s" % (
            HOST, d.port, d.pid, "without " + "/".join(NEW_FLAGS) if opt.no_new_flags else "all flags",
            seconds, seed, ", skipping " + ",".join(sorted(skip)) if skip else ""), flush=True)
        start_rss, start_fds = warm_up(d, rep)
        print("-- after the warm-up: RSS %s, %s open fds" % (mb(start_rss), start_fds), flush=True)
        load = Load(d, seconds, seed, skip)
        stuck = load.run()
        if stuck:
            rep.note("client threads still blocked after the load: " + ", ".join(stuck))
        report_load(load, d, rep, skip)
        settle(d, rep, start_rss, start_fds)
        sigterm(d, rep)
        if d.rc is not None or rep.failed:
            tail = d.log_tail(8)
            if tail:
                print("-- last lines of the daemon's log:")
                for line in tail.splitlines():
                    print("   " + line)
    finally:
        d.kill()
        if opt.keep:
            print("-- daemon log kept in " + d.log_path)
        else:
            shutil.rmtree(workdir, ignore_errors=True)
        print("fault: %d passed, %d failed" % (rep.passed, rep.failed), flush=True)
    return 1 if rep.failed else 0


if __name__ == "__main__":
    sys.exit(main())
