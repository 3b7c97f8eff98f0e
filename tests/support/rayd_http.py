"""What the Python tests of the daemon share: start `rayd serve` on
127.0.0.1 on a port it picks, send requests, stop it by its pid, count
checks. Standard library only."""
import http.client
import os
import signal
import struct
import subprocess
import sys
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
    flags and environment; its log in tmp. Raises RuntimeError when it does
    not start. Also a context manager that stops it."""

    def __init__(self, tmp, flags=(), env=None, listen="127.0.0.1:0", host="127.0.0.1"):
        port_file = os.path.join(tmp, "port")
        if os.path.exists(port_file):
            os.unlink(port_file)
        self.host = host
        self.log_path = os.path.join(tmp, "daemon.log")
        self.log = open(self.log_path, "wb")
        cmd = [RAYD, "serve", "--port-file", port_file] + (["--listen", listen] if listen else []) + list(flags)
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


def render_png(scene_path, out_path):
    """`rayd render` of a scene file: the PNG's bytes."""
    subprocess.run([RAYD, "render", scene_path, "-o", out_path], check=True, capture_output=True, timeout=300)
    with open(out_path, "rb") as f:
        return f.read()
