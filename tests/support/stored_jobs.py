"""What the stored-job tests (store_test.py, farm_test.py, same_bytes_test.py)
share: the query of a job's overrides, its status and image as a test reads
them, waiting for jobs to end, comparing an image's pixels with `rayd
render`'s, a run bounded in time that stops its servers and keeps its
folders only when a check failed (cpu_test.py too), and the job store of
the engine RAYD_TEST_STORE names (store())."""

import json
import os
import re
import shutil
import signal
import sqlite3
import sys
import tempfile
import time

from rayd_http import decode_png
from servers import PostgreSQL

ENDED = ("done", "failed", "cancelled")

TILES = "rayd_farm_tiles_total"

# The 20 small jobs both tests submit: scenes and sizes taking 0.05 to 0.7 s
# each on one core of this machine.
SCENES = ["phong.cfg", "diffuse.cfg", "area_light.cfg", "cook_torrance.cfg", "spot_light.cfg",
          "blinn_phong.cfg", "specular_refraction.cfg", "directional_light.cfg"]
if os.path.exists("scenes/generated/knot.obj"):
    SCENES.append("mesh.cfg")
SIZES = [(160, 120, 16), (320, 240, 8), (240, 180, 16)]
JOBS = [(SCENES[i % len(SCENES)], {"width": SIZES[i % 3][0], "height": SIZES[i % 3][1],
                                   "samples": SIZES[i % 3][2], "seed": i + 1}) for i in range(20)]


class Abort(Exception):
    """Ends the run early; the message is recorded as a failure."""


class OutOfTime(Exception):
    pass


def on_alarm(signum, frame):
    raise OutOfTime()


def bounded_run(check, name, bound_s, body, started, kept, closers, kept_what="the logs"):
    """body() under an alarm of bound_s seconds: an Abort or running out of
    time is a failed check. Then every Daemon of started still running is
    killed and every function of closers is called (PostgreSQL's close,
    nginx's stop), in order. The folders of kept are removed when every
    check passed, named on stderr otherwise (as kept_what). body may add to
    all three lists. Returns check.summary()."""
    signal.signal(signal.SIGALRM, on_alarm)
    signal.alarm(bound_s)
    try:
        body()
    except Abort as e:
        check(False, str(e))
    except OutOfTime:
        check(False, "the run took longer than its bound of %d s" % bound_s)
    finally:
        signal.alarm(0)
        for d in started:
            if d.proc.poll() is None:
                d.kill()
        for close in closers:
            close()
    if check.failed:
        print("%s: %s are in %s" % (name, kept_what, " ".join(kept)), file=sys.stderr)
    else:
        for d in kept:
            shutil.rmtree(d, ignore_errors=True)
    return check.summary()


def postgresql(prefix, kept, closers):
    """A PostgreSQL of the test's own (servers.PostgreSQL) in a new folder,
    added to kept, its close to closers (bounded_run's lists); Abort when
    it does not start."""
    try:
        pg = PostgreSQL(tempfile.mkdtemp(prefix=prefix))
    except RuntimeError as e:
        raise Abort("PostgreSQL did not start: %s" % e)
    kept.append(pg.dir)
    closers.append(pg.close)
    return pg


ENGINES = ("sqlite", "postgresql")


def engine():
    """The store engine RAYD_TEST_STORE names: sqlite (unset or empty) or
    postgresql; ValueError for another name."""
    name = os.environ.get("RAYD_TEST_STORE") or "sqlite"
    if name not in ENGINES:
        raise ValueError("RAYD_TEST_STORE=%s: not one of %s" % (name, ", ".join(ENGINES)))
    return name


class SQLiteStore:
    """The embedded store in the folder data: `rayd serve --data-dir data`."""

    engine = "sqlite"

    def __init__(self, data):
        self.data = data
        self.flags = ["--data-dir", data]

    def execute(self, sql, *params):
        """One statement written into the store directly, ? for each
        parameter; the number of rows it changed. Abort when it fails."""
        try:
            db = sqlite3.connect(os.path.join(self.data, "rayd.sqlite3"), timeout=10)
            try:
                with db:
                    return db.execute(sql, params).rowcount
            finally:
                db.close()
        except sqlite3.Error as e:
            raise Abort("sqlite3 %s: %s" % (sql, e))


class PostgreSQLStore:
    """A PostgreSQL of the test's own (postgresql()): `rayd serve --store
    URL`; statements written into it directly go through psql."""

    engine = "postgresql"

    def __init__(self, pg):
        self.pg = pg
        self.flags = ["--store", pg.url]

    def execute(self, sql, *params):
        """As SQLiteStore.execute: each ? is its parameter as a quoted
        literal (text; the SQL itself holds no other ?)."""
        parts = sql.split("?")
        if len(parts) != len(params) + 1:
            raise ValueError("%d parameters for %d ? in %s" % (len(params), len(parts) - 1, sql))
        text = parts[0] + "".join("'%s'%s" % (str(v).replace("'", "''"), rest) for v, rest in zip(params, parts[1:]))
        rc, out = self.pg.psql(self.pg.database, text)
        # psql -t prints a statement's tag: UPDATE 1, DELETE 0, INSERT 0 1.
        m = re.search(r"^(?:UPDATE|DELETE|INSERT \d+) (\d+)$", out, re.M)
        if rc != 0 or not m:
            raise Abort("psql %s: exit %d: %s" % (text, rc, out.strip()[-500:]))
        return int(m.group(1))


def store(tmp, kept, closers):
    """The job store of engine(): SQLite in tmp/data, or a PostgreSQL of the
    test's own (postgresql(), so kept and closers are bounded_run's);
    Abort when it cannot be had."""
    try:
        name = engine()
    except ValueError as e:
        raise Abort(str(e))
    if name == "postgresql":
        return PostgreSQLStore(postgresql("rayd-store-pg-", kept, closers))
    return SQLiteStore(os.path.join(tmp, "data"))


def scene_bytes(scene):
    with open(os.path.join("scenes", scene), "rb") as f:
        return f.read()


class Headers:
    """What every answer's X-Rayd-Daemon said: saw() each answer with the
    ids it may carry (None: any), report() through check."""

    def __init__(self, check):
        self.check, self.answers, self.missing, self.wrong = check, 0, [], []

    def saw(self, what, headers, want):
        self.answers += 1
        got = headers.get("x-rayd-daemon")
        if got is None:
            self.missing.append(what)
        elif want and got not in want:
            self.wrong.append("%s: %r, not %s" % (what, got, "/".join(want)))

    def report(self):
        self.check(self.answers > 0 and not self.missing, "%d of %d answers had no X-Rayd-Daemon, the first: %s" %
                   (len(self.missing), self.answers, self.missing[:3]))
        self.check(not self.wrong, "X-Rayd-Daemon is not the answering daemon's --daemon-id: %s" % self.wrong[:3])


def query(overrides):
    """{"width": 160, ...} as a query string."""
    return "&".join("%s=%s" % kv for kv in overrides.items())


def status_json(status, body):
    """A GET /v1/jobs/ID answer as a dict; {"status": "http 404"} and the
    like when it is not a job's status."""
    if status != 200:
        return {"status": "http %d" % status, "body": body[:200]}
    try:
        return json.loads(body)
    except ValueError:
        return {"status": "not JSON", "body": body[:200]}


def png_body(status, headers, body):
    """A GET /v1/jobs/ID/image answer's PNG, or None."""
    if status == 200 and headers.get("content-type", "").startswith("image/png"):
        return body
    return None


def wait_done(check, poll, ids, timeout, what):
    """Polls poll(id) (a status dict) until every job has ended or is gone;
    their last statuses, one failed check for those not done."""
    deadline, last = time.time() + timeout, {}
    while True:
        last = {jid: poll(jid) for jid in ids}
        if all(s.get("status") in ENDED or s.get("status", "").startswith("http 404") for s in last.values()) \
                or time.time() > deadline:
            break
        time.sleep(0.1)
    left = {jid: s.get("status") for jid, s in last.items() if s.get("status") != "done"}
    check(not left, "%s: %d of %d jobs are not done after %.0f s: %s" %
          (what, len(left), len(ids), timeout, dict(list(left.items())[:5])))
    for jid, s in last.items():
        if s.get("status") == "failed":
            print("  job %s failed: %s" % (jid, s.get("error")), file=sys.stderr)
    return last


def same_pixels(check, png_bytes, ref, what):
    """ref: decode_png of `rayd render`'s PNG."""
    if png_bytes is None:
        return check(False, "%s: no PNG" % what)
    try:
        got = decode_png(png_bytes)
    except ValueError as e:
        return check(False, "%s: the PNG does not decode: %s" % (what, e))
    if got[:2] != ref[:2]:
        return check(False, "%s: %dx%d, the CLI's is %dx%d" % (what, got[0], got[1], ref[0], ref[1]))
    diff = sum(1 for a, b in zip(got[2], ref[2]) if a != b)
    return check(got[2] == ref[2], "%s: %d of %d samples differ from `rayd render`'s" % (what, diff, len(ref[2])))
