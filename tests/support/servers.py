"""The servers the farm and store tests run beside rayd: a PostgreSQL 15 of
their own and nginx in front of several daemons. Both listen on 127.0.0.1
only, on ports picked here, keep everything (data, sockets, logs, pid and
temporary files) in the folder they are given, and are stopped by their
pid. Standard library only.

PostgreSQL(tmpdir): initdb into tmpdir/data, pg_ctl start on 127.0.0.1 and a
free port, the Unix socket in tmpdir, CREATE DATABASE rayd. initdb refuses
root: as root the folder is given to the postgres user (Debian's package
postgresql makes it) and the server's commands run through
`runuser -u postgres`, as tests/support/pg_server.c does for the C tests.
.url is postgresql://postgres@127.0.0.1:PORT/rayd (.database: rayd); .stop() (fast shutdown,
data kept) and .start() (same folder, same port) may alternate; .close()
stops it for good. A guard process stops the server if the test process
dies without doing so (kill -9, a CI timeout), and .close() runs at exit.

Nginx(tmpdir, upstream_ports, conf_path): the site file
deploy/nginx/rayd.conf (a conf.d-level file: `upstream rayd { ... server
127.0.0.1:8081 ...; }` one line per daemon, and a `server { listen 80; ...
}` block) copied with the upstream lines' ports replaced by the given ones
(lines past them dropped, the last one repeated for more) and `listen 80;`
made `listen 127.0.0.1:PORT;`, included by a top-level nginx.conf written in
tmpdir; `nginx -t`, then nginx in the foreground as a child of the test.
.port, .stop() by its pid.

Missing binaries, a missing user or a server that does not start raise
RuntimeError naming the reason and the end of the server's log.
"""
import atexit
import glob
import os
import re
import shutil
import signal
import socket
import stat
import subprocess
import sys
import time

_GUARD = r"""
import os, sys
data = sys.stdin.buffer.read()
if not data:
    os.execvp("sh", ["sh", "-c", sys.argv[1]])
"""


class _Guard:
    """A process that runs a shell command once the test process is gone
    (its pipe reaches end of file), unless disarmed first."""

    def __init__(self, command):
        self.proc = subprocess.Popen([sys.executable, "-c", _GUARD, command], stdin=subprocess.PIPE,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)

    def disarm(self):
        if self.proc.stdin:
            try:
                self.proc.stdin.write(b"x")
                self.proc.stdin.close()
            except OSError:
                pass
            self.proc.stdin = None
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def free_port():
    """A port on 127.0.0.1 that was free a moment ago."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def port_open(port, host="127.0.0.1", timeout=0.5):
    try:
        socket.create_connection((host, port), timeout=timeout).close()
        return True
    except OSError:
        return False


def _tail(path, n=1500):
    try:
        with open(path, "rb") as f:
            f.seek(0, os.SEEK_END)
            f.seek(max(0, f.tell() - n))
            return f.read().decode("utf-8", "replace")
    except OSError:
        return "(no log at %s)" % path


def _pg_bin():
    env = os.environ.get("RAYD_PG_BIN")
    if env:
        return env
    best = None
    for d in glob.glob("/usr/lib/postgresql/*/bin"):
        v = os.path.basename(os.path.dirname(d))
        if v.isdigit() and os.access(os.path.join(d, "pg_ctl"), os.X_OK) and (best is None or int(v) > best[0]):
            best = (int(v), d)
    if not best:
        raise RuntimeError("PostgreSQL's server binaries are missing (no /usr/lib/postgresql/N/bin/pg_ctl, "
                           "$RAYD_PG_BIN unset): install the Debian package postgresql (make deps)")
    return best[1]


def _runuser():
    for p in ("/usr/sbin/runuser", "/sbin/runuser", "/usr/bin/runuser"):
        if os.access(p, os.X_OK):
            return p
    raise RuntimeError("running as root, PostgreSQL's commands need runuser (util-linux)")


class PostgreSQL:
    """A private PostgreSQL server in tmpdir (see the module's text)."""

    def __init__(self, tmpdir, database="rayd"):
        if not stat.S_ISCHR(os.stat("/dev/null").st_mode):
            raise RuntimeError("/dev/null is not a device: initdb needs it (mknod -m 666 /dev/null c 1 3)")
        self.dir = os.path.abspath(tmpdir)
        os.makedirs(self.dir, exist_ok=True)
        self.bin = _pg_bin()
        self.data = os.path.join(self.dir, "data")
        self.log_path = os.path.join(self.dir, "server.log")
        self.port, self.pid, self.user = None, 0, "postgres"
        self.as_user = []
        if os.geteuid() == 0:
            import pwd
            try:
                pw = pwd.getpwnam("postgres")
            except KeyError:
                raise RuntimeError("running as root, PostgreSQL needs the user postgres "
                                   "(made by the Debian package postgresql)")
            self.as_user = [_runuser(), "-u", "postgres", "--"]
            os.chown(self.dir, pw.pw_uid, pw.pw_gid)
            self._check_reachable()
        self.guard = _Guard("[ -f '%s/postmaster.pid' ] && %s '%s/pg_ctl' -D '%s' -m immediate -w -t 20 stop" %
                            (self.data, " ".join(self.as_user), self.bin, self.data))
        atexit.register(self.close)
        self._tool("initdb", ["-D", self.data, "-N", "-A", "trust", "-U", "postgres", "-E", "UTF8", "--locale=C"],
                   60, "initdb failed in %s" % self.dir)
        # The port was free a moment ago; another process may take it first.
        for _ in range(3):
            self.port = free_port()
            if self._start_once():
                break
        else:
            raise RuntimeError("PostgreSQL did not start in %s:\n%s" % (self.dir, _tail(self.log_path)))
        self.url = self.create_database(database)
        self.database = database

    def _check_reachable(self):
        """The postgres user must reach the folder: every folder above it
        searchable by others."""
        d = self.dir
        while d != "/":
            d = os.path.dirname(d)
            if not os.stat(d).st_mode & 0o001:
                raise RuntimeError("the postgres user cannot reach %s: %s is not searchable by others "
                                   "(give PostgreSQL a folder of its own, e.g. tempfile.mkdtemp())" % (self.dir, d))

    def _tool(self, tool, args, timeout, what=None):
        """bin/tool args as the server's user, its output appended to the
        log; raises RuntimeError with `what` when it fails, else returns
        its exit status."""
        with open(self.log_path, "ab") as log:
            try:
                rc = subprocess.run(self.as_user + [os.path.join(self.bin, tool)] + args, cwd=self.dir,
                                    stdin=subprocess.DEVNULL, stdout=log, stderr=log, timeout=timeout).returncode
            except subprocess.TimeoutExpired:
                rc = -1
        if rc != 0 and what:
            raise RuntimeError("%s (exit %d):\n%s" % (what, rc, _tail(self.log_path)))
        return rc

    def _read_pid(self):
        try:
            with open(os.path.join(self.data, "postmaster.pid")) as f:
                return int(f.readline())
        except (OSError, ValueError):
            return 0

    def _start_once(self):
        # fsync and friends off: a test's data need not survive the machine.
        opts = ("-c listen_addresses=127.0.0.1 -p %d -c unix_socket_directories=%s -c fsync=off "
                "-c full_page_writes=off -c synchronous_commit=off -c max_connections=60 -c shared_buffers=16MB"
                % (self.port, self.dir))
        if self._tool("pg_ctl", ["-D", self.data, "-w", "-t", "30", "-o", opts, "start"], 40) != 0:
            return False
        self.pid = self._read_pid()
        return self.pid > 0

    @property
    def running(self):
        return self.pid > 0

    def start(self):
        """Starts the stopped server again: same data, same port."""
        if self.running:
            raise RuntimeError("PostgreSQL runs already")
        if not self._start_once():
            raise RuntimeError("PostgreSQL did not start again on port %d:\n%s" % (self.port, _tail(self.log_path)))

    def stop(self):
        """Fast shutdown (sessions are ended), data kept; by its pid if
        pg_ctl fails."""
        if not self.running:
            return
        if self._tool("pg_ctl", ["-D", self.data, "-m", "fast", "-w", "-t", "20", "stop"], 30) != 0:
            try:
                os.kill(self.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        for _ in range(500):
            try:
                os.kill(self.pid, 0)
            except ProcessLookupError:
                break
            time.sleep(0.01)
        self.pid = 0

    def create_database(self, name):
        """CREATE DATABASE name (letters, digits, _); its URL."""
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
            raise ValueError("a database name of letters, digits and _: %r" % name)
        self._tool("createdb", ["-h", "127.0.0.1", "-p", str(self.port), "-U", "postgres", name], 30,
                   "CREATE DATABASE %s failed" % name)
        return "postgresql://%s@127.0.0.1:%d/%s" % (self.user, self.port, name)

    def psql(self, database, sql, timeout=30):
        """One statement through psql: (exit status, its output)."""
        p = subprocess.run([os.path.join(self.bin, "psql"), "-X", "-A", "-t", "-v", "ON_ERROR_STOP=1", "-h",
                            "127.0.0.1", "-p", str(self.port), "-U", "postgres", "-d", database, "-c", sql],
                           capture_output=True, timeout=timeout, stdin=subprocess.DEVNULL)
        return p.returncode, (p.stdout + p.stderr).decode("utf-8", "replace")

    def log(self):
        return _tail(self.log_path, 100000)

    def close(self):
        """Stops it for good (the folder stays, for the caller to remove)."""
        self.stop()
        self.guard.disarm()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


NGINX_CONF = "deploy/nginx/rayd.conf"
_UPSTREAM_LINE = re.compile(r"^(\s*server\s+)(127\.0\.0\.1|localhost|\[::1\]):(\d+)(.*;.*)$")
_LISTEN = re.compile(r"^(\s*listen\s+)(\S+)(.*;.*)$")
_LOG = re.compile(r"^(\s*(access_log|error_log)\s+)([^\s;]+)(.*;.*)$")


def site_conf(text, upstream_ports, port, log_dir=None):
    """The site file's text for these ports: the upstream block's server
    lines carry upstream_ports, in place of the first (extra lines dropped,
    the last repeated for more ports); its first `listen` is
    127.0.0.1:port, other listen lines (IPv6, 443) go; with log_dir, its
    own access_log and error_log files are made files of that folder.
    Raises ValueError when the file has no such lines."""
    lines = text.split("\n")
    servers, upstream, depth = [], False, 0
    for i, line in enumerate(lines):
        code = line.split("#", 1)[0]
        if not upstream and re.match(r"\s*upstream\s+\S+\s*\{", code):
            upstream, depth = True, 0
        if upstream:
            m = _UPSTREAM_LINE.match(code)
            if m and depth == 1:
                servers.append((i, m))
            depth += code.count("{") - code.count("}")
            if depth <= 0 and "}" in code:
                upstream = False
    if not servers:
        raise ValueError("no `upstream NAME { server 127.0.0.1:PORT ...; }` block")
    where = {i for i, _ in servers}
    out, listened = [], False
    for i, line in enumerate(lines):
        if i == servers[0][0]:
            for n, p in enumerate(upstream_ports):
                m = servers[min(n, len(servers) - 1)][1]
                out.append("%s127.0.0.1:%d%s" % (m.group(1), p, m.group(4)))
        if i in where:
            continue
        m = _LOG.match(line.split("#", 1)[0])
        if m and log_dir and m.group(3) != "off":
            line = "%s%s/site-%s%s" % (m.group(1), log_dir, os.path.basename(m.group(3)), m.group(4))
        m = _LISTEN.match(line.split("#", 1)[0])
        if m:
            if not listened:
                opts = re.sub(r"\b(default_server|reuseport|ipv6only=\S+)", "", m.group(3))
                out.append("%s127.0.0.1:%d%s" % (m.group(1), port, opts if opts.strip() != ";" else ";"))
                listened = True
            continue
        out.append(line)
    if not listened:
        raise ValueError("no `listen` line")
    return "\n".join(out)


class Nginx:
    """nginx in front of daemons on upstream_ports (see the module's text)."""

    def __init__(self, tmpdir, upstream_ports, conf_path=None):
        conf_path = conf_path or os.environ.get("RAYD_NGINX_CONF", NGINX_CONF)
        self.exe = shutil.which("nginx") or ("/usr/sbin/nginx" if os.access("/usr/sbin/nginx", os.X_OK) else None)
        if not self.exe:
            raise RuntimeError("nginx is not installed (the Debian package nginx; make deps)")
        if not os.path.exists(conf_path):
            raise RuntimeError("%s is missing: nothing to put in front of the daemons" % conf_path)
        self.dir = os.path.abspath(tmpdir)
        os.makedirs(self.dir, exist_ok=True)
        # Its workers run as www-data when the master is root: they write
        # the temporary files here.
        os.chmod(self.dir, 0o755)
        self.error_log = os.path.join(self.dir, "error.log")
        self.access_log = os.path.join(self.dir, "access.log")
        self.proc, self.guard = None, None
        with open(conf_path) as f:
            site = f.read()
        for _ in range(3):
            self.port = free_port()
            with open(os.path.join(self.dir, "rayd.conf"), "w") as f:
                try:
                    f.write(site_conf(site, upstream_ports, self.port, self.dir))
                except ValueError as e:
                    raise RuntimeError("%s: %s (one directive a line)" % (conf_path, e))
            self.conf = self._write_main()
            self._test()
            if self._start():
                atexit.register(self.stop)
                return
        raise RuntimeError("nginx did not start:\n%s" % _tail(self.error_log))

    def _write_main(self):
        d = self.dir
        user = ""
        if os.geteuid() == 0:
            import pwd
            try:
                pwd.getpwnam("www-data")
                user = "user www-data;\n"
            except KeyError:
                user = "user nobody nogroup;\n"
        text = (user +
                "worker_processes 1;\n"
                "daemon off;\n"
                "pid %s/nginx.pid;\n"
                "error_log %s info;\n"
                "events { worker_connections 512; }\n"
                "http {\n"
                "    access_log %s;\n"
                "    client_body_temp_path %s/client_body;\n"
                "    proxy_temp_path %s/proxy;\n"
                "    fastcgi_temp_path %s/fastcgi;\n"
                "    uwsgi_temp_path %s/uwsgi;\n"
                "    scgi_temp_path %s/scgi;\n"
                "    include %s/rayd.conf;\n"
                "}\n") % (d, self.error_log, self.access_log, d, d, d, d, d, d)
        path = os.path.join(d, "nginx.conf")
        with open(path, "w") as f:
            f.write(text)
        return path

    def _cmd(self, *extra):
        return [self.exe, "-p", self.dir + "/", "-e", self.error_log, "-c", self.conf] + list(extra)

    def _test(self):
        p = subprocess.run(self._cmd("-t"), capture_output=True, timeout=30, stdin=subprocess.DEVNULL)
        if p.returncode != 0:
            raise RuntimeError("nginx -t refused the configuration (%s):\n%s" %
                               (self.conf, (p.stdout + p.stderr).decode("utf-8", "replace")))

    def _start(self):
        log = open(os.path.join(self.dir, "nginx.out"), "ab")
        self.proc = subprocess.Popen(self._cmd(), stdin=subprocess.DEVNULL, stdout=log, stderr=log)
        log.close()
        self.guard = _Guard("kill -TERM %d 2>/dev/null" % self.proc.pid)
        deadline = time.time() + 10
        while time.time() < deadline:
            if self.proc.poll() is not None:
                self.guard.disarm()
                return False  # most likely the port was taken meanwhile
            if port_open(self.port):
                return True
            time.sleep(0.02)
        self.stop()
        return False

    @property
    def pid(self):
        return self.proc.pid if self.proc else 0

    def log(self):
        return _tail(self.error_log, 100000)

    def stop(self):
        """SIGTERM (nginx's fast shutdown) to its pid; SIGKILL after 10 s.
        Its exit status."""
        if not self.proc:
            return None
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if self.guard:
            self.guard.disarm()
            self.guard = None
        return self.proc.returncode

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()
