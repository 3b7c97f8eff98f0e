"""Section 10, the job store: what keeping asynchronous jobs costs, and how
far one PostgreSQL carries a farm.

1. Durability per job: small jobs (scenes/phong.cfg, 32x24) through POST
   /v1/jobs on a SQLite store (--data-dir, synchronous=FULL) and on
   PostgreSQL (--store), against synchronous POST /v1/render of the same
   scene, the in-memory path. One at a time (POST, the 202, polls of GET
   /v1/jobs/{id} 1 ms apart until done, GET /v1/jobs/{id}/image), the three
   variants in turn; then bursts (one client posts them all back to back,
   then waits for each and reads its image; the synchronous burst is two
   clients), each variant in turn, --runs times. The cost of durability is
   the difference in ms per job; the 202's latency is the commit.
2. The farm: one large job (scenes/area_light.cfg, 1920x1080, 2 samples, one
   pass of 510 tiles of 64 pixels, about 3 s on 2 threads) by two daemons
   of --threads 1 on one PostgreSQL, by one daemon of --threads 2 on the
   same server (a database of its own), by one of --threads 2 on SQLite, and
   by POST /v1/render on a daemon of --threads 2 (in memory); the four in
   turn, --runs times, wall time from the POST to done seen (polls 20 ms
   apart). Overhead = farm / one daemon of 2 threads - 1, per run, the
   median of the runs. How the tiles split (rayd_farm_tiles_total of each
   daemon), the CPU seconds of the daemons and of PostgreSQL, and whether
   every variant's PNG is the same bytes.
3. Claims: (a) the tiles per second one daemon (--threads 2, PostgreSQL)
   renders of scenes/phong.cfg at 1920x1080 in 64-pixel tiles, at 1 and at
   16 samples, with the in-memory render of the same for its render time;
   a typical tile's stored result of each (the median stored size) is read
   from the database for (b).
   (b) bench/store_claims: 1, 2, 4 and 8 threads, each with its own store
   handle, claim a tile and store a result (16 bytes, or the real 1- or
   16-sample tile), on PostgreSQL as started here, with
   synchronous_commit=off, with a queue of 20 jobs instead of 2, and on
   SQLite; each configuration in turn, --runs times, the median. (c) Daemons
   end to end: 1, 2 and 4 daemons of --threads 1 on a job of 8-pixel tiles
   (--store-tile 8) of phong.cfg at 1 sample, tiles per second from their
   rayd_farm_tiles_total. The daemons one database feeds = its claim rate /
   the tiles per second of one daemon.

PostgreSQL is tests/support/servers.py's private server (initdb in the
scratch folder, 127.0.0.1, a free port, stopped by its pid), but started
with PostgreSQL's defaults (fsync, synchronous_commit and full_page_writes
on) instead of the tests' fsync=off: the commits are what is measured. The
database, the daemons and the clients share this machine's cores."""
import glob
import json
import os
import shutil
import statistics
import sys
import tempfile
import threading
import time

from .. import measure, report

TITLE = "the job store: durability per job, a farm on one PostgreSQL, claims per second"
TOOLS = ("make", "cc", "pkg-config")

ENDED = ("done", "failed", "cancelled")
CLK = os.sysconf("SC_CLK_TCK")


# ---------------------------------------------------------------- servers

def postgresql(ctx):
    """A PostgreSQL of the section's own, with the server's durable defaults."""
    support = os.path.join(ctx.root, "tests", "support")
    if support not in sys.path:
        sys.path.insert(0, support)
    import servers

    class Durable(servers.PostgreSQL):
        """servers.PostgreSQL started without the tests' fsync=off,
        full_page_writes=off and synchronous_commit=off."""

        def _start_once(self):
            opts = "-c listen_addresses=127.0.0.1 -p %d -c unix_socket_directories=%s" % (self.port, self.dir)
            if self._tool("pg_ctl", ["-D", self.data, "-w", "-t", "30", "-o", opts, "start"], 40) != 0:
                return False
            self.pid = self._read_pid()
            return self.pid > 0

    # A folder of its own: the scratch folder is private to this user, and
    # the server runs as postgres when the driver is root.
    folder = tempfile.mkdtemp(prefix="rayd-bench-pg.", dir="/tmp")
    try:
        return Durable(folder)
    except RuntimeError as e:
        shutil.rmtree(folder, ignore_errors=True)
        raise measure.Failed("PostgreSQL did not start: %s" % e)


def pg_show(pg, db, sql):
    rc, out = pg.psql(db, sql)
    return out.strip() if rc == 0 else None


def pg_cpu(pg):
    """CPU seconds of the server and its backends so far."""
    total = 0.0
    for stat in glob.glob("/proc/[0-9]*/stat"):
        try:
            with open(stat) as f:
                text = f.read()
        except OSError:
            continue
        pid = int(stat.split("/")[2])
        rest = text.rsplit(")", 1)[1].split()
        if pid == pg.pid or int(rest[1]) == pg.pid:
            total += (int(rest[11]) + int(rest[12])) / CLK
    return total


def proc_cpu(pid):
    try:
        with open("/proc/%d/stat" % pid) as f:
            rest = f.read().rsplit(")", 1)[1].split()
        return (int(rest[11]) + int(rest[12])) / CLK
    except OSError:
        return None


def filesystem(path):
    """(type, device) of the mount holding path."""
    best = ("?", "?", "")
    try:
        with open("/proc/mounts") as f:
            for line in f:
                dev, mnt, typ = line.split()[:3]
                if (path == mnt or path.startswith(mnt.rstrip("/") + "/")) and len(mnt) >= len(best[2]):
                    best = (typ, dev, mnt)
    except OSError:
        pass
    return {"type": best[0], "device": best[1]}


def daemon(ctx, name, *flags):
    """rayd serve bound to 127.0.0.1 with its own data folder (the SQLite
    store, or unused beside --store)."""
    return measure.Server(measure.rayd_serve_cmd(ctx.rayd, "--data-dir", ctx.path(name + "-var"), "--daemon-id",
                                                 name, "--queue", "256", *flags), ctx.path(name + ".log"))


def tiles_of(rd):
    return measure.metrics(rd).get("rayd_farm_tiles_total", 0.0)


# ---------------------------------------------------------------- jobs over HTTP

def post_job(rd, query, body):
    """POST /v1/jobs: (job id, seconds to the 202)."""
    status, _, data, secs = measure.request(rd.url("/v1/jobs?" + query), "POST", body, "text/plain", timeout=30)
    if status != 202:
        raise measure.Failed("POST /v1/jobs?%s answered %d: %s" % (query, status, data[:300]))
    return json.loads(data)["id"], secs


def wait_done(rd, jid, poll_s, limit_s):
    """Polls GET /v1/jobs/{id} until it has ended: (its JSON, polls)."""
    deadline = time.monotonic() + limit_s
    polls = 0
    while True:
        info = measure.get_json(rd.url("/v1/jobs/" + jid))
        polls += 1
        if info["status"] in ENDED:
            break
        if time.monotonic() > deadline:
            measure.request(rd.url("/v1/jobs/" + jid), "DELETE", timeout=10)
            raise measure.Failed("job %s not done after %g s: %s" % (jid, limit_s, info.get("status")))
        time.sleep(poll_s)
    if info["status"] != "done":
        raise measure.Failed("job %s ended %s: %s" % (jid, info["status"], json.dumps(info)[:300]))
    return info, polls


def image(rd, jid):
    status, headers, data, _ = measure.request(rd.url("/v1/jobs/%s/image" % jid), timeout=60)
    if status != 200 or not headers.get("content-type", "").startswith("image/png"):
        raise measure.Failed("GET /v1/jobs/%s/image answered %d" % (jid, status))
    return data


def render_sync(rd, query, body, timeout=120):
    """POST /v1/render: (PNG, seconds, the daemon's render ms)."""
    status, headers, data, secs = measure.request(rd.url("/v1/render?" + query), "POST", body, "text/plain",
                                                  timeout=timeout)
    if status != 200:
        raise measure.Failed("POST /v1/render?%s answered %d: %s" % (query, status, data[:300]))
    return data, secs, float(headers.get("x-rayd-render-ms", "nan"))


def job_round(rd, query, body, poll_s, limit_s):
    """One job through the store: POST, polls until done, its image."""
    t0 = time.perf_counter()
    jid, post_s = post_job(rd, query, body)
    info, polls = wait_done(rd, jid, poll_s, limit_s)
    t_done = time.perf_counter()
    png = image(rd, jid)
    t_img = time.perf_counter()
    return {"post_ms": post_s * 1e3, "done_ms": (t_done - t0) * 1e3, "total_ms": (t_img - t0) * 1e3,
            "queued_ms": info.get("queued_ms"), "elapsed_ms": info.get("elapsed_ms"), "polls": polls,
            "png_bytes": len(png)}, png


def pct(values, p):
    return measure.percentile([v for v in values if v is not None], p)


def median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


# ---------------------------------------------------------------- 1. durability per job

def part_jobs(ctx, pg):
    n_seq = 10 if ctx.quick else 60
    n_burst = 10 if ctx.quick else 50
    w, h = 32, 24
    query = "width=%d&height=%d" % (w, h)
    with open(os.path.join(ctx.root, "scenes", "phong.cfg"), "rb") as f:
        body = f.read()
    url = pg.create_database("jobs")
    with daemon(ctx, "jobs-sqlite", "--threads", "2") as sq, \
            daemon(ctx, "jobs-pg", "--threads", "2", "--store", url) as pq:
        variants = [("memory", sq), ("sqlite", sq), ("postgresql", pq)]

        def one(name, rd):
            if name == "memory":
                _, secs, render_ms = render_sync(rd, query, body)
                return {"total_ms": secs * 1e3, "render_ms": render_ms}
            return job_round(rd, query, body, 0.001, 30)[0]

        for name, rd in variants:  # warm-up
            for _ in range(3):
                one(name, rd)
        print("  %d small jobs one at a time, 3 variants in turn ..." % n_seq, flush=True)
        seq = {name: [] for name, _ in variants}
        for i in range(n_seq):
            for k in range(len(variants)):
                name, rd = variants[(i + k) % len(variants)]
                seq[name].append(one(name, rd))

        def burst(name, rd):
            t0 = time.perf_counter()
            if name == "memory":
                times, errors = [], []

                def client(k):
                    try:
                        for _ in range(k):
                            times.append(render_sync(rd, query, body)[1] * 1e3)
                    except measure.Failed as e:
                        errors.append(str(e))
                th = [threading.Thread(target=client, args=(n_burst // 2 + (n_burst % 2 if i == 0 else 0),))
                      for i in range(2)]
                for t in th:
                    t.start()
                for t in th:
                    t.join(120)
                if errors or any(t.is_alive() for t in th):
                    raise measure.Failed("synchronous burst: %s" % (errors[:1] or "a client did not end"))
                secs = time.perf_counter() - t0
                return {"jobs": n_burst, "seconds": secs, "jobs_per_s": n_burst / secs,
                        "render_p50_ms": pct(times, 50)}
            ids, posts = [], []
            for _ in range(n_burst):
                jid, s = post_job(rd, query, body)
                ids.append(jid)
                posts.append(s * 1e3)
            t_posted = time.perf_counter()
            for jid in ids:
                wait_done(rd, jid, 0.002, 120)
            for jid in ids:
                image(rd, jid)
            secs = time.perf_counter() - t0
            return {"jobs": n_burst, "seconds": secs, "jobs_per_s": n_burst / secs,
                    "post_seconds": t_posted - t0, "post_p50_ms": pct(posts, 50), "post_p95_ms": pct(posts, 95),
                    "post_max_ms": max(posts)}

        print("  bursts of %d jobs, %d run(s), in turn ..." % (n_burst, ctx.runs), flush=True)
        bursts = {name: [] for name, _ in variants}
        for r in range(ctx.runs):
            for k in range(len(variants)):
                name, rd = variants[(r + k) % len(variants)]
                bursts[name].append(burst(name, rd))
                measure.wait_idle(rd)
    summary = {}
    mem_seq = median([x["total_ms"] for x in seq["memory"]])
    for name, _ in variants:
        s = seq[name]
        row = {"total_p50_ms": pct([x["total_ms"] for x in s], 50),
               "total_p95_ms": pct([x["total_ms"] for x in s], 95),
               "burst_jobs_per_s": median([b["jobs_per_s"] for b in bursts[name]])}
        if name != "memory":
            row.update(post_p50_ms=pct([x["post_ms"] for x in s], 50), post_p95_ms=pct([x["post_ms"] for x in s], 95),
                       done_p50_ms=pct([x["done_ms"] for x in s], 50),
                       queued_p50_ms=pct([x["queued_ms"] for x in s], 50),
                       elapsed_p50_ms=pct([x["elapsed_ms"] for x in s], 50),
                       burst_post_p50_ms=median([b["post_p50_ms"] for b in bursts[name]]),
                       burst_post_p95_ms=median([b["post_p95_ms"] for b in bursts[name]]),
                       cost_ms=row["total_p50_ms"] - mem_seq,
                       # ms of the machine per job, each run's burst against the
                       # synchronous burst of the same run
                       burst_cost_ms=median([1e3 / b["jobs_per_s"] - 1e3 / m["jobs_per_s"]
                                             for b, m in zip(bursts[name], bursts["memory"])]))
        summary[name] = row
    return {"settings": {"scene": "phong.cfg", "size": [w, h], "sequential": n_seq, "burst": n_burst,
                         "render_threads": 2, "poll_ms": 1},
            "sequential": seq, "bursts": bursts, "summary": summary}


# ---------------------------------------------------------------- 2. the farm

def part_farm(ctx, pg):
    w, h, spp = (480, 270, 1) if ctx.quick else (1920, 1080, 2)
    scene = "area_light.cfg"
    query = "width=%d&height=%d&samples=%d" % (w, h, spp)
    with open(os.path.join(ctx.root, "scenes", scene), "rb") as f:
        body = f.read()
    single_url, farm_url = pg.create_database("single"), pg.create_database("farm")
    limit = 60 if ctx.quick else 300
    runs = []
    with daemon(ctx, "farm-sqlite", "--threads", "2") as sq, \
            daemon(ctx, "single", "--threads", "2", "--store", single_url) as one, \
            daemon(ctx, "farm-a", "--threads", "1", "--store", farm_url) as fa, \
            daemon(ctx, "farm-b", "--threads", "1", "--store", farm_url) as fb:
        who = {"memory": [sq], "sqlite": [sq], "postgresql": [one], "farm": [fa, fb]}

        def go(name, query=query):
            rds = who[name]
            cpu0 = [proc_cpu(rd.pid) for rd in rds]
            pg0 = pg_cpu(pg)
            if name == "memory":
                png, secs, render_ms = render_sync(rds[0], query, body, timeout=limit)
                rec = {"wall_ms": secs * 1e3, "render_ms": render_ms}
            else:
                t0 = [tiles_of(rd) for rd in rds]
                t_start = time.perf_counter()
                jid, post_s = post_job(rds[0], query, body)
                info, _ = wait_done(rds[0], jid, 0.02, limit)
                wall = (time.perf_counter() - t_start) * 1e3
                png = image(rds[0], jid)
                rec = {"wall_ms": wall, "post_ms": post_s * 1e3, "elapsed_ms": info.get("elapsed_ms"),
                       "queued_ms": info.get("queued_ms"),
                       "tiles": [tiles_of(rd) - t for rd, t in zip(rds, t0)]}
            rec["rayd_cpu_s"] = sum((proc_cpu(rd.pid) or 0) - (c or 0) for rd, c in zip(rds, cpu0))
            rec["postgresql_cpu_s"] = pg_cpu(pg) - pg0
            rec["png_bytes"] = len(png)
            return rec, png

        print("  warm-up ...", flush=True)
        for name in who:
            go(name, "width=320&height=180&samples=1")
        pngs = {}
        for r in range(ctx.runs):
            order = ["memory", "sqlite", "postgresql", "farm"] if r % 2 == 0 else ["memory", "sqlite", "farm",
                                                                                   "postgresql"]
            rec = {}
            for name in order:
                print("  run %d of %d: %s ..." % (r + 1, ctx.runs, name), flush=True)
                rec[name], png = go(name)
                pngs.setdefault(name, set()).add(png)
            rec["load"] = measure.loadavg()[0]
            runs.append(rec)
    ref = next(iter(pngs["memory"]))
    same = {name: len(p) == 1 and next(iter(p)) == ref for name, p in pngs.items()}
    ratio = lambda a, b: median([x[a]["wall_ms"] / x[b]["wall_ms"] for x in runs])  # noqa: E731
    tiles_total = sum(runs[0]["farm"]["tiles"])
    summary = {
        "wall_ms": {name: median([x[name]["wall_ms"] for x in runs]) for name in who},
        "rayd_cpu_s": {name: median([x[name]["rayd_cpu_s"] for x in runs]) for name in who},
        "postgresql_cpu_s": {name: median([x[name]["postgresql_cpu_s"] for x in runs]) for name in who},
        "farm_over_postgresql": ratio("farm", "postgresql"), "farm_over_memory": ratio("farm", "memory"),
        "postgresql_over_memory": ratio("postgresql", "memory"), "sqlite_over_memory": ratio("sqlite", "memory"),
        "tiles": tiles_total,
        "farm_split": [median([x["farm"]["tiles"][i] / max(1, sum(x["farm"]["tiles"])) for x in runs])
                       for i in range(2)],
        "same_png": same,
    }
    summary["overhead"] = summary["farm_over_postgresql"] - 1
    return {"settings": {"scene": scene, "size": [w, h], "samples": spp, "store_tile": 64, "poll_ms": 20,
                         "limit_s": limit},
            "runs": runs, "summary": summary}


# ---------------------------------------------------------------- 3. claims

def capture_tile(pg, db, rd, query, body, tiles, path, limit):
    """Posts a job and reads one of its stored tile results (the renderer's
    state of a 64-pixel tile) from the database while the job runs: of
    the tiles stored so far, the one whose stored size is the median (a
    typical tile: plain background compresses, busy tiles do not), once a
    third of them are in; waits for the job to end. {path, bytes,
    stored_bytes (PostgreSQL's pg_column_size, after its compression),
    tile, among} or None."""
    jid, _ = post_job(rd, query, body)
    sql = ("WITH s AS (SELECT tile, pg_column_size(data) AS n FROM tiles WHERE job_id = '%s' AND data IS NOT NULL), "
           "m AS (SELECT tile FROM s ORDER BY n, tile OFFSET (SELECT count(*) / 2 FROM s) LIMIT 1) "
           "SELECT (SELECT count(*) FROM s) || ' ' || t.tile || ' ' || pg_column_size(t.data) || ' ' || "
           "encode(t.data, 'hex') FROM tiles t JOIN m ON t.tile = m.tile WHERE t.job_id = '%s'" % (jid, jid))
    got, deadline = None, time.monotonic() + limit
    while time.monotonic() < deadline:
        rc, out = pg.psql(db, sql)
        out = out.strip()
        if rc == 0 and out:
            among, tile, stored, hexed = out.split(" ", 3)
            got = {"among": int(among), "tile": int(tile), "stored_bytes": int(stored),
                   "data": bytes.fromhex(hexed.replace("\n", ""))}
            if got["among"] * 3 >= tiles:
                break
        if measure.get_json(rd.url("/v1/jobs/" + jid))["status"] in ENDED:
            break
        time.sleep(0.02)
    wait_done(rd, jid, 0.05, limit)
    if got is None:
        return None
    with open(path, "wb") as f:
        f.write(got.pop("data"))
    got.update(path=path, bytes=os.path.getsize(path))
    return got


def part_tile_rate(ctx, pg):
    """Tiles per second one daemon of 2 threads renders and stores."""
    # Whole tiles only: 20x11 of them at 1 sample, 10x6 at 16 (quick: 5x3).
    sizes = {1: (320, 192), 16: (320, 192)} if ctx.quick else {1: (1280, 704), 16: (640, 384)}
    sample_counts = (1, 16)
    limit = 60 if ctx.quick else 300
    with open(os.path.join(ctx.root, "scenes", "phong.cfg"), "rb") as f:
        body = f.read()
    url = pg.create_database("tiles")
    payloads = {}
    rows = {s: [] for s in sample_counts}
    with daemon(ctx, "tiles", "--threads", "2", "--store", url) as rd:
        for s in sample_counts:
            q = "width=%d&height=%d&samples=%d" % (sizes[s] + (s,))
            w, h = sizes[s]
            c = capture_tile(pg, "tiles", rd, q, body, (w // 64) * (h // 64), ctx.path("tile-%dspp.bin" % s), limit)
            if c:
                payloads[s] = c
        for r in range(ctx.runs):
            for s in sample_counts:
                q = "width=%d&height=%d&samples=%d" % (sizes[s] + (s,))
                print("  run %d of %d: phong %dx%d, %d spp, in memory and stored ..." % ((r + 1, ctx.runs) + sizes[s]
                                                                                         + (s,)), flush=True)
                c0, p0 = proc_cpu(rd.pid), pg_cpu(pg)
                _, secs, render_ms = render_sync(rd, q, body, timeout=limit)
                c1, p1 = proc_cpu(rd.pid), pg_cpu(pg)
                t0 = tiles_of(rd)
                t_start = time.perf_counter()
                jid, _ = post_job(rd, q, body)
                info, _ = wait_done(rd, jid, 0.02, limit)
                wall = (time.perf_counter() - t_start) * 1e3
                tiles = tiles_of(rd) - t0
                c2, p2 = proc_cpu(rd.pid), pg_cpu(pg)
                rows[s].append({"memory_wall_ms": secs * 1e3, "memory_render_ms": render_ms, "stored_wall_ms": wall,
                                "elapsed_ms": info.get("elapsed_ms"), "tiles": tiles,
                                "tiles_per_s": tiles / wall * 1e3,
                                "memory_tiles_per_s": tiles / render_ms * 1e3,
                                "memory_rayd_cpu_s": c1 - c0, "memory_postgresql_cpu_s": p1 - p0,
                                "stored_rayd_cpu_s": c2 - c1, "stored_postgresql_cpu_s": p2 - p1})
    summary = {}
    for s in sample_counts:
        x = rows[s]
        tps = median([r["tiles_per_s"] for r in x])
        mem = median([r["memory_tiles_per_s"] for r in x])
        summary[s] = {"size": list(sizes[s]), "tiles": x[0]["tiles"], "tiles_per_s": tps, "memory_tiles_per_s": mem,
                      "ms_per_tile_thread": 2e3 / tps, "memory_ms_per_tile_thread": 2e3 / mem,
                      "memory_rayd_cpu_s": median([r["memory_rayd_cpu_s"] for r in x]),
                      "stored_rayd_cpu_s": median([r["stored_rayd_cpu_s"] for r in x]),
                      "stored_postgresql_cpu_s": median([r["stored_postgresql_cpu_s"] for r in x]),
                      "payload_bytes": payloads.get(s, {}).get("bytes"),
                      "payload_stored_bytes": payloads.get(s, {}).get("stored_bytes")}
    return {"settings": {"scene": "phong.cfg", "sizes": {str(k): list(v) for k, v in sizes.items()}, "threads": 2,
                         "store_tile": 64, "captured": {str(k): v for k, v in payloads.items()}},
            "rows": {str(k): v for k, v in rows.items()}, "summary": {str(k): v for k, v in summary.items()}}, payloads


def harness(ctx):
    """Builds bench/store_claims (make's rule; quick when up to date)."""
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL")}
    b = measure.run(["make", "-C", ctx.root, "--no-print-directory", "build/bench/store_claims"], env=env,
                    check=False, timeout=300)
    path = os.path.join(ctx.root, "build", "bench", "store_claims")
    if b.rc != 0 or not os.access(path, os.X_OK):
        raise measure.Failed("building build/bench/store_claims failed:\n  %s" % "\n  ".join(b.tail(10)))
    return path


def part_harness(ctx, pg, payloads):
    exe = harness(ctx)
    url = pg.create_database("claims")
    secs = 1 if ctx.quick else 2
    threads = (1, 4) if ctx.quick else (1, 2, 4, 8)
    loads = [("16 B", ["--payload-bytes", "16"])]
    for s in (1, 16):
        if s in payloads and not (ctx.quick and s == 16):
            loads.append(("%d-spp tile" % s, ["--payload", payloads[s]["path"]]))
    # 16-byte results at every thread count; real tiles at 1 and the
    # larger counts; SQLite (one writer at a time) at 1.
    few = threads[-1:] if ctx.quick else (1,) + threads[-2:]
    configs = []
    for name, args in loads:
        for n in (threads if name == "16 B" else few):
            configs.append(("postgresql", name, n, url, args))
    for n in few if ctx.quick else threads:
        configs.append(("postgresql, synchronous_commit=off", "16 B", n,
                        url + "?options=-csynchronous_commit%3Doff", ["--payload-bytes", "16"]))
    configs.append(("postgresql, queue of 20 jobs", "16 B", 2, url, ["--payload-bytes", "16", "--queue", "20"]))
    for name, args in loads[:1] if ctx.quick else loads[:2]:
        configs.append(("sqlite", name, 1, ctx.path("claims-sqlite"), args))
    results = {i: [] for i in range(len(configs))}
    for r in range(ctx.runs):
        print("  store_claims run %d of %d: %d configurations of %d s ..." % (r + 1, ctx.runs, len(configs), secs),
              flush=True)
        for i, (store, load, n, spec, args) in enumerate(configs):
            out = measure.run([exe, spec, "--threads", str(n), "--seconds", str(secs)] + args, timeout=secs + 120,
                              what="store_claims")
            try:
                results[i].append(json.loads(out.stdout))
            except ValueError:
                raise measure.Failed("store_claims printed no JSON object: %s" % "\n  ".join(out.tail()))
    rows = []
    for i, (store, load, n, spec, args) in enumerate(configs):
        x = results[i]
        rows.append({"store": store, "payload": load, "threads": n, "payload_bytes": x[0]["payload_bytes"],
                     "tiles_per_s": median([y["tiles_per_s"] for y in x]),
                     "claim_p50_ms": median([y["claim_p50_ms"] for y in x]),
                     "done_p50_ms": median([y["done_p50_ms"] for y in x]),
                     "errors": sum(sum(y["errors"].values()) for y in x), "runs": x})
    return {"settings": {"seconds": secs, "threads": list(threads), "tiles_per_job": 510, "queue": 2}, "rows": rows}


def part_daemons(ctx, pg):
    w, h = (160, 120) if ctx.quick else (320, 192)
    counts = (1, 2) if ctx.quick else (1, 2, 4)
    tile = 8
    query = "width=%d&height=%d&samples=1" % (w, h)
    with open(os.path.join(ctx.root, "scenes", "phong.cfg"), "rb") as f:
        body = f.read()
    rows = {k: [] for k in counts}
    groups = {}
    servers = []
    try:
        for k in counts:
            url = pg.create_database("tiny%d" % k)
            groups[k] = []
            for i in range(k):
                s = daemon(ctx, "tiny%d-%d" % (k, i), "--threads", "1", "--store-tile", str(tile), "--store", url)
                s.__enter__()
                servers.append(s)
                groups[k].append(s)
        for r in range(ctx.runs):
            for k in counts:
                print("  run %d of %d: %d daemon(s), %d tiles of %d px ..." % (
                    r + 1, ctx.runs, k, ((w + tile - 1) // tile) * ((h + tile - 1) // tile), tile), flush=True)
                rds = groups[k]
                t0 = [tiles_of(rd) for rd in rds]
                pg0 = pg_cpu(pg)
                t_start = time.perf_counter()
                jid, _ = post_job(rds[0], query, body)
                wait_done(rds[0], jid, 0.02, 120)
                wall = time.perf_counter() - t_start
                split = [tiles_of(rd) - t for rd, t in zip(rds, t0)]
                rows[k].append({"seconds": wall, "tiles": sum(split), "split": split,
                                "tiles_per_s": sum(split) / wall, "postgresql_cpu_s": pg_cpu(pg) - pg0})
    finally:
        for s in servers:
            s.stop()
    return {"settings": {"scene": "phong.cfg", "size": [w, h], "samples": 1, "store_tile": tile, "threads": 1},
            "rows": {str(k): v for k, v in rows.items()},
            "summary": {str(k): {"tiles_per_s": median([x["tiles_per_s"] for x in v]),
                                 "postgresql_cpu_s": median([x["postgresql_cpu_s"] for x in v]),
                                 "split": v[-1]["split"]} for k, v in rows.items()}}


# ---------------------------------------------------------------- the section

def run(ctx):
    pg = postgresql(ctx)
    try:
        info = {"version": pg_show(pg, "postgres", "SHOW server_version"),
                "fsync": pg_show(pg, "postgres", "SHOW fsync"),
                "synchronous_commit": pg_show(pg, "postgres", "SHOW synchronous_commit"),
                "full_page_writes": pg_show(pg, "postgres", "SHOW full_page_writes"),
                "shared_buffers": pg_show(pg, "postgres", "SHOW shared_buffers")}
        print("  PostgreSQL %s on 127.0.0.1:%d (fsync %s, synchronous_commit %s)" % (
            info["version"], pg.port, info["fsync"], info["synchronous_commit"]), flush=True)
        print("  1. durability per job ...", flush=True)
        jobs = part_jobs(ctx, pg)
        print("  2. the farm ...", flush=True)
        farm = part_farm(ctx, pg)
        print("  3. claims: one daemon's tiles per second ...", flush=True)
        tile_rate, payloads = part_tile_rate(ctx, pg)
        print("  3. claims: bench/store_claims ...", flush=True)
        claims = part_harness(ctx, pg, payloads)
        print("  3. claims: daemons end to end ...", flush=True)
        daemons = part_daemons(ctx, pg)
    finally:
        pg.close()
        if ctx.keep:
            print("  PostgreSQL's folder kept: %s" % pg.dir, file=sys.stderr)
        else:
            shutil.rmtree(pg.dir, ignore_errors=True)
    return {"settings": {"postgresql": info, "work_filesystem": filesystem(ctx.work), "cpus": ctx.cpus},
            "jobs": jobs, "farm": farm, "tile_rate": tile_rate, "claims": claims, "daemons": daemons,
            "estimate": estimate(tile_rate, claims)}


def estimate(tile_rate, claims):
    """Daemons one database feeds, per sample count: its best claim rate
    with that tile's real result (any thread count) over the tiles per
    second of one daemon of 2 threads, as it stored them (slowed by the
    same database) and as it renders them in memory (what it would ask of
    a database that kept up)."""
    est = {}
    for s in ("1", "16"):
        t = tile_rate["summary"][s]
        load = "%s-spp tile" % s
        pgrows = [r for r in claims["rows"] if r["store"] == "postgresql" and r["payload"] == load]
        if not pgrows:  # --quick measures no 16-sample payload
            pgrows = [r for r in claims["rows"] if r["store"] == "postgresql" and r["payload"] == "16 B"]
        best = max(pgrows, key=lambda r: r["tiles_per_s"])
        est[s] = {"claims_per_s": best["tiles_per_s"], "at_threads": best["threads"], "payload": best["payload"],
                  "daemon_tiles_per_s": t["tiles_per_s"], "daemons": best["tiles_per_s"] / t["tiles_per_s"],
                  "memory_tiles_per_s": t["memory_tiles_per_s"],
                  "daemons_at_render_rate": best["tiles_per_s"] / t["memory_tiles_per_s"]}
    return est


# ---------------------------------------------------------------- tables

f, n = report.f, report.n


def t_store_jobs(sec):
    j = sec["jobs"]
    s, u = j["settings"], j["summary"]
    m = u["memory"]
    rows = [["in memory (POST /v1/render)", f(m["total_p50_ms"], "%.2f"), f(m["total_p95_ms"], "%.2f"), "", "", "", "",
             f(m["burst_jobs_per_s"]), ""]]
    for name in ("sqlite", "postgresql"):
        x = u[name]
        rows.append(["%s store (POST /v1/jobs)" % ("SQLite" if name == "sqlite" else "PostgreSQL"),
                     f(x["total_p50_ms"], "%.2f"), f(x["total_p95_ms"], "%.2f"), f(x["cost_ms"], "%+.2f"),
                     "%s / %s" % (f(x["post_p50_ms"], "%.2f"), f(x["post_p95_ms"], "%.2f")),
                     "%s / %s" % (f(x["burst_post_p50_ms"], "%.2f"), f(x["burst_post_p95_ms"], "%.2f")),
                     "%s / %s" % (f(x["queued_p50_ms"], "%.0f"), f(x["elapsed_p50_ms"], "%.0f")),
                     f(x["burst_jobs_per_s"]), f(x["burst_cost_ms"], "%+.2f")])
    fs = sec["settings"]["work_filesystem"]
    return "\n".join([
        "scenes/phong.cfg %dx%d, daemons of 2 render threads; one at a time: %d jobs of each variant in turn (POST, "
        "polls 1 ms apart, the image); bursts of %d, median of the runs. SQLite on %s (%s), synchronous=FULL; "
        "PostgreSQL %s, fsync %s, synchronous_commit %s." % (
            s["size"][0], s["size"][1], s["sequential"], s["burst"], fs["type"], fs["device"],
            sec["settings"]["postgresql"]["version"], sec["settings"]["postgresql"]["fsync"],
            sec["settings"]["postgresql"]["synchronous_commit"]), "",
        report.table(["path", "one job p50 ms", "p95 ms", "cost ms/job", "202 p50 / p95 ms", "202 in a burst p50 / p95",
                      "queued / elapsed ms (p50)", "burst jobs/s", "burst cost ms/job"], rows)])


def t_store_farm(sec):
    fm = sec["farm"]
    s, u = fm["settings"], fm["summary"]
    labels = {"memory": "POST /v1/render, 1 daemon x 2 threads (in memory)",
              "sqlite": "1 daemon x 2 threads, SQLite", "postgresql": "1 daemon x 2 threads, PostgreSQL",
              "farm": "2 daemons x 1 thread, one PostgreSQL"}
    rows = []
    for name in ("memory", "sqlite", "postgresql", "farm"):
        over = 1.0 if name == "memory" else u["%s_over_memory" % name]
        rows.append([labels[name], f(u["wall_ms"][name], "%.0f"), f(over, "%.2f") + "x",
                     f(u["rayd_cpu_s"][name], "%.2f"), f(u["postgresql_cpu_s"][name], "%.2f"),
                     "yes" if u["same_png"][name] else "**no**"])
    per_run = ", ".join("%.3f" % (x["farm"]["wall_ms"] / x["postgresql"]["wall_ms"]) for x in fm["runs"])
    return "\n".join([
        "scenes/%s %dx%d, %d sample(s), one pass of %d tiles of %d px; wall time from the POST to done seen (polls "
        "%d ms apart); medians of the runs, of each run's ratio for / in memory." % (
            s["scene"], s["size"][0], s["size"][1], s["samples"], u["tiles"], s["store_tile"], s["poll_ms"]), "",
        report.table(["variant", "wall ms", "/ in memory", "rayd CPU s", "PostgreSQL CPU s", "PNG bytes = in memory"],
                     rows), "",
        "Coordination overhead of the farm = 2 daemons / 1 daemon of 2 threads on PostgreSQL - 1: **%+.1f%%** "
        "(per run: %s; target at most +10%%: %s). Tiles: %.0f%% by the daemon that took the POST, %.0f%% by the "
        "other." % (100 * u["overhead"], per_run, "met" if u["overhead"] <= 0.10 else "**not met**",
                    100 * u["farm_split"][0], 100 * u["farm_split"][1])])


def t_store_claims(sec):
    tr, cl, dm = sec["tile_rate"], sec["claims"], sec["daemons"]
    est = estimate(tr, cl)
    rows = []
    for s in ("1", "16"):
        t = tr["summary"][s]
        rows.append(["%s spp, %dx%d" % (s, t["size"][0], t["size"][1]), n(t["tiles"]), f(t["memory_tiles_per_s"]),
                     f(t["memory_ms_per_tile_thread"], "%.2f"), f(t["memory_rayd_cpu_s"], "%.2f"), f(t["tiles_per_s"]), f(t["ms_per_tile_thread"], "%.2f"),
                     f(t["stored_rayd_cpu_s"], "%.2f"), f(t["stored_postgresql_cpu_s"], "%.2f"),
                     "%s (%s)" % (n(t["payload_bytes"]), n(t.get("payload_stored_bytes")))])
    out = ["One daemon (--threads 2, PostgreSQL) on scenes/phong.cfg in 64-px tiles, median of the runs; in "
           "memory = the same render by POST /v1/render (its X-Rayd-Render-Ms); stored = POST /v1/jobs to done. A "
           "tile's result: the bytes (as PostgreSQL keeps them, after its own compression) of the tile of median "
           "stored size, read from the database mid-job; bench/store_claims stores these.",
           "",
           report.table(["samples", "tiles", "in-memory tiles/s", "ms per tile per thread", "rayd CPU s",
                         "stored tiles/s", "ms per tile per thread", "rayd CPU s", "PostgreSQL CPU s",
                         "tile result bytes (stored)"], rows), ""]
    crow = [[r["store"], r["payload"], r["threads"], f(r["tiles_per_s"]), f(r["claim_p50_ms"], "%.2f"),
             f(r["done_p50_ms"], "%.2f"), r["errors"]] for r in cl["rows"]]
    out += ["bench/store_claims: N threads, a handle each, claim one tile and store its result, %d s per "
            "configuration, a queue of %d jobs of %d tiles unless said, median of the runs." % (
                cl["settings"]["seconds"], cl["settings"]["queue"], cl["settings"]["tiles_per_job"]), "",
            report.table(["store", "result", "threads", "tiles/s", "claim p50 ms", "tile_done p50 ms", "errors"],
                         crow), ""]
    drow = [[k, f(v["tiles_per_s"]), f(v["postgresql_cpu_s"], "%.2f"), "/".join(str(int(x)) for x in v["split"])]
            for k, v in dm["summary"].items()]
    ds = dm["settings"]
    out += ["Daemons end to end: --threads 1 each, one PostgreSQL, scenes/phong.cfg %dx%d at 1 spp in tiles of %d px "
            "(%s tiles)." % (ds["size"][0], ds["size"][1], ds["store_tile"],
                             n(dm["rows"]["1"][0]["tiles"])), "",
            report.table(["daemons", "tiles/s", "PostgreSQL CPU s", "tiles per daemon (last run)"], drow), ""]
    erow = [["%s spp" % s, f(e["claims_per_s"]), "%s, %d threads" % (e["payload"], e["at_threads"]),
             f(e["daemon_tiles_per_s"]), f(e["daemons"], "%.2f"), f(e["memory_tiles_per_s"]),
             f(e["daemons_at_render_rate"], "%.2f")] for s, e in est.items()]
    out += ["Daemons one database feeds = its claims/s with that tile's result / the tiles/s of one daemon of 2 "
            "threads: as stored through this database, and as rendered in memory (what a daemon would ask of a "
            "database that kept up).", "",
            report.table(["64-px phong tiles at", "claims/s of the database", "measured with",
                          "one daemon, stored tiles/s", "daemons", "one daemon, in-memory tiles/s", "daemons"],
                         erow)]
    return "\n".join(out)


# The tables, for the driver's print-out and report.py's generated blocks.
report.MARKERS.setdefault("store-jobs", ("store", t_store_jobs))
report.MARKERS.setdefault("store-farm", ("store", t_store_farm))
report.MARKERS.setdefault("store-claims", ("store", t_store_claims))
