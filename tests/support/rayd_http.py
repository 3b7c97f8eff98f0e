"""What the Python tests of the daemon share: start `rayd serve` on
127.0.0.1 on a port it picks, send requests, stop it by its pid, count
checks. Standard library only."""
import http.client
import os
import select
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
import uuid
import zlib

RAYD = os.environ.get("RAYD", "build/rayd")


class Checks:
    """Counts checks; prints each failure as it happens."""

    def __init__(self, name):
        self.name, self.passed, self.failed = name, 0, 0

    def __call__(self, cond, what):
        if cond:
            self.passed += 1
        else:
            self.failed += 1
            print("FAIL:", what, file=sys.stderr)
        return cond

    def summary(self):
        print("%s: %d passed, %d failed" % (self.name, self.passed, self.failed))
        return 1 if self.failed or not self.passed else 0


class Daemon:
    """`rayd serve --listen LISTEN` (127.0.0.1:0 by default) with extra
    flags and environment (wrap: a command that runs it, such as setpriv);
    its log in tmp. Raises RuntimeError when it does
    not start. Also a context manager that stops it."""

    def __init__(self, tmp, flags=(), env=None, listen="127.0.0.1:0", host="127.0.0.1", wrap=()):
        port_file = os.path.join(tmp, "port")
        if os.path.exists(port_file):
            os.unlink(port_file)
        self.host = host
        self.log_path = os.path.join(tmp, "daemon.log")
        self.log = open(self.log_path, "wb")
        cmd = list(wrap) + [RAYD, "serve", "--port-file", port_file] + (["--listen", listen] if listen else []) + list(flags)
        # Each daemon its own job store unless the test names one.
        base = dict(os.environ, RAYD_DATA_DIR=os.path.join(tmp, "var"))
        self.proc = subprocess.Popen(cmd, stdout=self.log, stderr=self.log, stdin=subprocess.DEVNULL,
                                     env=dict(base, **(env or {})))
        for _ in range(1000):
            if os.path.exists(port_file) and open(port_file).read().strip():
                self.port = int(open(port_file).read())
                return
            if self.proc.poll() is not None:
                break
            time.sleep(0.02)
        self.proc.kill()
        self.proc.wait()
        self.log.close()
        raise RuntimeError("the daemon did not start (exit %s): %s" % (self.proc.returncode, self.text()[-500:]))

    def text(self):
        """What it has logged so far."""
        with open(self.log_path, "rb") as f:
            return f.read().decode("utf-8", "replace")

    def send(self, sig):
        self.proc.send_signal(sig)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()

    terminated = False

    def terminate(self):
        """SIGTERM: it drains, then exits."""
        self.terminated = True
        self.proc.send_signal(signal.SIGTERM)

    @property
    def pid(self):
        return self.proc.pid

    def request(self, method, path, body=None, headers=None, timeout=120):
        """(status, headers as a lower-cased dict, body bytes)."""
        c = http.client.HTTPConnection(self.host, self.port, timeout=timeout)
        try:
            c.request(method, path, body=body, headers=headers or {})
            r = c.getresponse()
            return r.status, {k.lower(): v for k, v in r.getheaders()}, r.read()
        finally:
            c.close()

    def kill(self):
        """SIGKILL to its pid, as a crash: no draining, nothing given back.
        Its exit status."""
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        return self.stop()

    def stop(self):
        """SIGTERM to its pid (unless already sent); the exit status (-1 if
        it had to be killed)."""
        if self.proc.poll() is not None:
            self.log.close()
            return self.proc.returncode
        if not self.terminated:
            self.terminate()
        try:
            rc = self.proc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            rc = -1
        self.log.close()
        return rc


def png(width, height, rgb_of):
    """An 8-bit RGB PNG whose pixel (x, y) is rgb_of(x, y)."""
    rows = b"".join(b"\0" + bytes(c for x in range(width) for c in rgb_of(x, y)) for y in range(height))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def form(fields):
    """A multipart/form-data body and its Content-Type for {name: bytes}."""
    boundary = uuid.uuid4().hex
    body = b""
    for name, value in fields.items():
        filename = '; filename="%s"' % name if name in ("image", "scene") else ""
        body += ('--%s\r\nContent-Disposition: form-data; name="%s"%s\r\n\r\n' %
                 (boundary, name, filename)).encode() + value + b"\r\n"
    return body + ("--%s--\r\n" % boundary).encode(), "multipart/form-data; boundary=" + boundary


def form_parts(parts):
    """A multipart/form-data body and its Content-Type for a list of
    (name, filename or None, bytes): names may repeat, in order. A filename
    given as bytes goes in as those bytes (a name that is not UTF-8)."""
    boundary = uuid.uuid4().hex
    body = b""
    for name, filename, value in parts:
        if isinstance(filename, str):
            filename = filename.encode()
        fn = b'; filename="' + filename + b'"' if filename is not None else b""
        body += ('--%s\r\nContent-Disposition: form-data; name="%s"' % (boundary, name)).encode() + fn + \
            b"\r\n\r\n" + value + b"\r\n"
    return body + ("--%s--\r\n" % boundary).encode(), "multipart/form-data; boundary=" + boundary


def render_png(scene_path, out_path):
    """`rayd render` of a scene file: the PNG's bytes."""
    subprocess.run([RAYD, "render", scene_path, "-o", out_path], check=True, capture_output=True, timeout=300)
    with open(out_path, "rb") as f:
        return f.read()


def cli_render(scene_path, out_path, overrides=None, extra=()):
    """`rayd render` of a scene file with overrides ({"width": 160, ...},
    the flags of the same names): the PNG's bytes."""
    args = [RAYD, "render", scene_path, "-o", out_path, "--quiet"] + list(extra)
    for k, v in (overrides or {}).items():
        args += ["--" + k.replace("_", "-"), str(v)]
    subprocess.run(args, check=True, capture_output=True, timeout=300)
    with open(out_path, "rb") as f:
        return f.read()


def raw_post(port, path, body, headers):
    """A POST on a socket of its own, left open: the caller hangs up
    (close) or sees whether the answer has begun (answered)."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=30)
    head = "POST %s HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: %d\r\n" % (path, len(body))
    head += "".join("%s: %s\r\n" % kv for kv in headers.items())
    sock.sendall(head.encode() + b"\r\n" + body)
    return sock


def answered(sock):
    """Whether a raw_post's socket has something to read: an answer (or an
    interim 102), or its end."""
    return bool(select.select([sock], [], [], 0)[0])


def http_request(host, port, method, path, body=None, headers=None, timeout=120):
    """A request to any server (nginx in front of daemons, say): (status,
    headers as a lower-cased dict, body bytes), as Daemon.request."""
    c = http.client.HTTPConnection(host, port, timeout=timeout)
    try:
        c.request(method, path, body=body, headers=headers or {})
        r = c.getresponse()
        return r.status, {k.lower(): v for k, v in r.getheaders()}, r.read()
    finally:
        c.close()


def metric_value(text, name, labels=None):
    """A sample's value in a /metrics text (bytes or str), or None when the
    series is not there. labels: {"k": "v"} exactly, or none."""
    if isinstance(text, bytes):
        text = text.decode("utf-8", "replace")
    want = ",".join('%s="%s"' % kv for kv in sorted((labels or {}).items()))
    for line in text.split("\n"):
        if not line.startswith(name) or line.startswith("#"):
            continue
        rest = line[len(name):]
        got = ""
        if rest.startswith("{"):
            got, rest = rest[1:].split("}", 1)
            got = ",".join(sorted(p for p in got.split(",") if p))
        if rest[:1] == " " and got == want:
            try:
                return float(rest.split()[0])
            except ValueError:
                return None
    return None


def decode_png(data):
    """A PNG's pixels, whatever its encoder chose (filters, chunking,
    level): (width, height, RGB bytes), gray and palette made RGB, an alpha
    channel dropped when every pixel is opaque (kept, as RGBA bytes,
    otherwise). 16-bit samples stay two bytes. Raises ValueError on what is
    not such a PNG (interlaced ones included)."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    pos, idat, plte, ihdr = 8, [], None, None
    while pos + 8 <= len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        chunk = data[pos + 8:pos + 8 + n]
        if len(chunk) != n or struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])[0] != zlib.crc32(kind + chunk):
            raise ValueError("a damaged %r chunk" % kind)
        pos += 12 + n
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", chunk)
        elif kind == b"PLTE":
            plte = chunk
        elif kind == b"IDAT":
            idat.append(chunk)
        elif kind == b"IEND":
            break
    if not ihdr or not idat:
        raise ValueError("no IHDR or IDAT")
    w, h, depth, ctype, _, _, interlace = ihdr
    if interlace or depth not in (1, 2, 4, 8, 16) or ctype not in (0, 2, 3, 4, 6):
        raise ValueError("an interlaced or unusual PNG (depth %d, color type %d)" % (depth, ctype))
    channels = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}[ctype]
    bpp = max(1, channels * depth // 8)
    stride = (w * channels * depth + 7) // 8
    raw = zlib.decompress(b"".join(idat))
    if len(raw) < h * (stride + 1):
        raise ValueError("the image data is short")
    out, prev = bytearray(), bytearray(stride)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        if f == 1:
            for i in range(bpp, stride):
                line[i] = (line[i] + line[i - bpp]) & 255
        elif f == 2:
            for i in range(stride):
                line[i] = (line[i] + prev[i]) & 255
        elif f == 3:
            for i in range(stride):
                line[i] = (line[i] + ((line[i - bpp] if i >= bpp else 0) + prev[i]) // 2) & 255
        elif f == 4:
            for i in range(stride):
                a, b = (line[i - bpp] if i >= bpp else 0), prev[i]
                c = prev[i - bpp] if i >= bpp else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        elif f != 0:
            raise ValueError("filter %d on row %d" % (f, y))
        out += line
        prev = line
    if depth < 8:
        per = 8 // depth
        samples = bytearray()
        for y in range(h):
            row = out[y * stride:(y + 1) * stride]
            samples += bytes((row[x // per] >> (8 - depth * (x % per + 1))) & ((1 << depth) - 1) for x in range(w))
        out = samples
        if ctype == 0:
            out = bytearray(v * 255 // ((1 << depth) - 1) for v in out)
        depth = 8
    size = depth // 8
    if ctype == 3:
        if not plte:
            raise ValueError("a palette PNG without PLTE")
        out = bytearray(b"".join(plte[3 * i:3 * i + 3] for i in out))
    elif ctype in (0, 4):
        px = channels * size
        out = bytearray(b"".join(out[i:i + size] * 3 + out[i + size:i + px] for i in range(0, len(out), px)))
        channels += 2
    if channels == 4:
        opaque = all(out[i:i + size] == b"\xff" * size for i in range(3 * size, len(out), 4 * size))
        if opaque:
            out = bytearray(b"".join(out[i:i + 3 * size] for i in range(0, len(out), 4 * size)))
    return w, h, bytes(out)


# A 16x12 diffuse sphere under one point light: a quick render.
TINY_SCENE = ("[render]\nwidth = 16\nheight = 12\n[light]\ntype = point\nposition = 0 5 5\ncolor = 1 1 1\n"
              "[material m]\ntype = diffuse\nkd = 0.5 0.5 0.5\n[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = m\n")
# One pixel takes minutes: 65536 samples under a 64x64-sample area light.
RUNAWAY_SCENE = ("[render]\nwidth = 4\nheight = 1\nsamples = 65536\n[camera]\neye = 0 2 6\ntarget = 0 0.5 0\n"
                 "[light]\ntype = area\ncorner = -1 6 -1\nedge1 = 2 0 0\nedge2 = 0 0 2\nsamples = 64\ncolor = 1 1 1\n"
                 "[material m]\ntype = diffuse\nkd = 0.7 0.7 0.7\n[sphere]\ncenter = 0 0.8 0\nradius = 0.8\n"
                 "material = m\n[plane]\npoint = 0 0 0\nnormal = 0 1 0\nmaterial = m\n")


def tiny_assignments(tmp, broken=False):
    """tmp/assignments with `tiny` (TINY_SCENE, a quick reference) and, when
    asked, `broken` (a .grade file that does not read)."""
    path = os.path.join(tmp, "assignments")
    os.makedirs(path)
    files = {"tiny.cfg": TINY_SCENE, "tiny.grade": "title = a tiny sphere\n"}
    if broken:
        files.update({"broken.cfg": TINY_SCENE, "broken.grade": "title = broken\nfail = three\n"})
    for name, text in files.items():
        with open(os.path.join(path, name), "w") as f:
            f.write(text)
    return path


def start_runaway(d, headers, timeout=10):
    """POST /v1/render of RUNAWAY_SCENE on a thread, returned once the daemon
    counts it running (or after timeout s)."""
    def post():
        try:
            d.request("POST", "/v1/render", body=RUNAWAY_SCENE.encode(), headers=headers)
        except OSError:
            pass
    t = threading.Thread(target=post, daemon=True)
    t.start()
    t0 = time.time()
    while time.time() - t0 < timeout and b"rayd_jobs_running 1" not in d.request("GET", "/metrics")[2]:
        time.sleep(0.05)
    return t
