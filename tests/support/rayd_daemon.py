"""A real `rayd serve` for the Python tests: started on 127.0.0.1 (or the
address given) on a port it picks, talked to with urllib, stopped by its pid.

    with Daemon(["--threads", "1"]) as d:
        status, headers, body = d.request("GET", "/healthz")
"""
import http.client
import os
import signal
import subprocess
import tempfile
import time

RAYD = os.environ.get("RAYD", "build/rayd")


class Daemon:
    def __init__(self, args=(), env=None, listen="127.0.0.1:0", host="127.0.0.1", cwd=None, rayd=None):
        self.args = list(args)
        self.env = env
        self.listen = listen
        self.host = host
        self.cwd = cwd
        self.rayd = os.path.abspath(rayd or RAYD)
        self.dir = tempfile.mkdtemp(prefix="rayd-test-")
        self.log_path = os.path.join(self.dir, "stderr.log")
        self.port_file = os.path.join(self.dir, "port")
        self.proc = None
        self.port = None

    def start(self, timeout=20):
        cmd = [self.rayd, "serve", "--port-file", self.port_file] + self.args
        if self.listen is not None:
            cmd += ["--listen", self.listen]
        env = dict(os.environ)
        env.update(self.env or {})
        with open(self.log_path, "wb") as log:
            self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=log, stderr=log, env=env,
                                         cwd=self.cwd)
        deadline = time.time() + timeout
        while time.time() < deadline:
            if os.path.exists(self.port_file):
                with open(self.port_file) as f:
                    text = f.read().strip()
                if text:
                    self.port = int(text)
                    return self
            if self.proc.poll() is not None:
                raise RuntimeError("rayd serve exited %d: %s" % (self.proc.returncode, self.log()))
            time.sleep(0.05)
        self.stop()
        raise RuntimeError("rayd serve did not start: " + self.log())

    def log(self):
        with open(self.log_path, "rb") as f:
            return f.read().decode("utf-8", "replace")

    def request(self, method, path, body=None, headers=None, timeout=60):
        """(status, {lower-case header: value}, body bytes)."""
        conn = http.client.HTTPConnection(self.host, self.port, timeout=timeout)
        try:
            conn.request(method, path, body=body, headers=headers or {})
            resp = conn.getresponse()
            data = resp.read()
            return resp.status, {k.lower(): v for k, v in resp.getheaders()}, data
        finally:
            conn.close()

    def send(self, sig):
        self.proc.send_signal(sig)

    def stop(self, sig=signal.SIGTERM, timeout=30):
        """Stops it by its pid; returns its exit status."""
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        return self.proc.returncode if self.proc else None

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()


class Checks:
    """Counts passes and failures; report() prints the total, returns the exit status."""

    def __init__(self, name):
        self.name = name
        self.passed = self.failed = 0

    def check(self, cond, what):
        if cond:
            self.passed += 1
        else:
            self.failed += 1
            print("FAIL:", what, flush=True)
        return cond

    def report(self):
        print("%s: %d passed, %d failed" % (self.name, self.passed, self.failed))
        return 1 if self.failed else 0
