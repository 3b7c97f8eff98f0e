"""Section 6, overload: rayd's capacity for the 640x480 phong render (wrk,
closed loop), then 3 times that rate at a fixed arrival rate (hey) against
--queue 4. Only 200 and 503 may come back, the accepted requests keep a
bounded latency, and memory and open files come back to where they were.

hey's CSV gives every answer's status and time; rayd's own count comes
from /metrics (rayd_http_responses_total by status class), read just
before and just after the load, so the only other request counted between
the two is one of those reads."""
import os
import subprocess
import time

from .. import measure

TITLE = "3x capacity at a fixed arrival rate (hey) against rayd --queue 4"
TOOLS = ("wrk", "hey")

QUEUE = 4
# hey workers: each sends at rate/WORKERS, so a worker waits on its own
# request for at most a few of its periods.
WORKERS = 32
CLASSES = ("1xx", "2xx", "3xx", "4xx", "5xx")


def classes(m):
    return {c: m.get('rayd_http_responses_total{code="%s"}' % c, 0.0) for c in CLASSES}


def run(ctx):
    url_q = "/v1/render?width=640&height=480"
    body_path = os.path.join(ctx.root, "scenes", "phong.cfg")
    with open(body_path, "rb") as f:
        body = f.read()
    with measure.Server(measure.rayd_serve_cmd(ctx.rayd, "--queue", str(QUEUE)), ctx.path("rayd-ovl.log")) as rd:
        fresh = measure.rss_fds(rd.pid)
        for _ in range(3):
            status = measure.request(rd.url(url_q), "POST", body, "text/plain")[0]
            if status != 200:
                raise measure.Failed("warm-up POST %s answered %d" % (url_q, status))
        # Capacity: 3 clients keep both render threads busy and stay under
        # the queue's 4 jobs.
        print("  capacity (wrk -c3) ...", flush=True)
        cap = measure.wrk(ctx.work, rd.url(url_q), body_path, 3, 2 if ctx.quick else 5)
        measure.wait_idle(rd)
        time.sleep(1)
        before = measure.rss_fds(rd.pid)
        rate = 3 * cap["rps"]
        q = rate / WORKERS
        m0 = classes(measure.metrics(rd))
        print("  hey -z %ds -q %.4f -c %d (%.1f req/s) ..." % (ctx.overload_secs, q, WORKERS, rate), flush=True)
        hey = subprocess.Popen(["hey", "-z", "%ds" % ctx.overload_secs, "-q", "%.4f" % q, "-c", str(WORKERS),
                                "-t", "30", "-m", "POST", "-T", "text/plain", "-D", body_path, "-o", "csv",
                                rd.url(url_q)], stdout=open(ctx.path("hey.csv"), "wb"),
                               stderr=open(ctx.path("hey.err"), "wb"))
        peak_rss, peak_fds = before
        deadline = time.monotonic() + ctx.overload_secs + 60
        try:
            while hey.poll() is None:
                if time.monotonic() > deadline:
                    hey.kill()
                    raise measure.Failed("hey ran past its bound")
                rss, fds = measure.rss_fds(rd.pid)
                peak_rss = max(peak_rss or 0, rss or 0)
                peak_fds = max(peak_fds or 0, fds or 0)
                time.sleep(0.2)
        finally:
            if hey.poll() is None:
                hey.kill()
            hey.wait()
        t_end = time.monotonic()
        m1 = classes(measure.metrics(rd))
        if hey.returncode != 0:
            raise measure.Failed("hey failed (status %d): %s" % (hey.returncode, open(ctx.path("hey.err")).read()[:300]))
        after = []
        for t in (1, 2, 3, 5):
            while time.monotonic() - t_end < t:
                time.sleep(0.05)
            rss, fds = measure.rss_fds(rd.pid)
            after.append({"seconds": t, "rss_kb": rss, "fds": fds})
        measure.wait_idle(rd)
    with open(ctx.path("hey.csv")) as f:
        answers = measure.hey_csv(f.read())
    codes = {}
    for _, code, _ in answers:
        codes[str(code)] = codes.get(str(code), 0) + 1
    served = {c: int(m1[c] - m0[c]) for c in CLASSES}
    served["2xx"] -= 1  # one GET /metrics
    last = max((o for _, _, o in answers), default=0.0)
    lat = {k: [s * 1000 for s, c, _ in answers if sel(c)] for k, sel in
           (("200", lambda c: c == 200), ("503", lambda c: c == 503), ("all", lambda c: True))}
    back = None
    for a in after:
        tol = max(0.10 * before[0], 2048)
        if back is None and a["fds"] == before[1] and a["rss_kb"] is not None and a["rss_kb"] <= before[0] + tol:
            back = a["seconds"]
    return {"settings": {"queue": QUEUE, "workers": WORKERS, "seconds": ctx.overload_secs, "size": [640, 480],
                         "render_threads": ctx.cpus},
            "capacity": cap, "offered_rps": rate, "hey_q": q, "answered": len(answers),
            "sent_rps": len(answers) / last if last > 0 else None,
            "codes": codes, "rayd_responses": served,
            "latency_ms": {k: {"p50": measure.percentile(v, 50), "p99": measure.percentile(v, 99), "n": len(v)}
                           for k, v in lat.items()},
            "memory": {"fresh": {"rss_kb": fresh[0], "fds": fresh[1]}, "before": {"rss_kb": before[0], "fds": before[1]},
                       "peak": {"rss_kb": peak_rss, "fds": peak_fds}, "after": after},
            "back_after_s": back, "rayd_exit": rd.rc}
