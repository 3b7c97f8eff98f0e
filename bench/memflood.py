#!/usr/bin/env python3
"""Memory under a flood of large jobs: N asynchronous 4096x4096 renders at
once against one `rayd serve`, its resident memory sampled every 100 ms until
every job has ended. Prints one JSON object: the budget, the peak RSS
(sampled and the kernel's VmHWM), the most jobs running at once, how many
waited for memory, and the outcomes.

    python3 bench/memflood.py BINARY [--jobs 64] [--budget BYTES] [--query Q]

Bounded: at most --jobs requests plus one status poll per job per second,
and --timeout seconds in all (default 600); the daemon binds 127.0.0.1 on a
port it picks and is stopped by its pid."""
import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request


def rss_kb(pid, key="VmRSS"):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    return 0


def metric(port, name):
    with urllib.request.urlopen("http://127.0.0.1:%d/metrics" % port, timeout=10) as r:
        for line in r.read().decode().splitlines():
            if line.startswith(name + " "):
                return float(line.split()[1])
    return 0.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("binary")
    ap.add_argument("--jobs", type=int, default=64)
    ap.add_argument("--budget", type=int, default=0, help="--memory-budget; 0: the daemon's default")
    ap.add_argument("--query", default="width=4096&height=4096&samples=1")
    ap.add_argument("--scene", default="scenes/phong.cfg")
    ap.add_argument("--timeout", type=float, default=600)
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="rayd-memflood-")
    port_file = os.path.join(tmp, "port")
    cmd = [a.binary, "serve", "--listen", "127.0.0.1:0", "--port-file", port_file, "--scenes", "scenes",
           "--queue", str(a.jobs), "--job-timeout-ms", "0", "--data-dir", os.path.join(tmp, "var")]
    if a.budget:
        cmd += ["--memory-budget", str(a.budget)]
    log = open(os.path.join(tmp, "log"), "w")
    d = subprocess.Popen(cmd, stderr=log)
    t0 = time.monotonic()
    while not os.path.exists(port_file) and time.monotonic() - t0 < 10:
        time.sleep(0.05)
    port = int(open(port_file).read())
    body = open(a.scene, "rb").read()
    start_rss = rss_kb(d.pid)
    ids, codes = [], {}
    for _ in range(a.jobs):
        req = urllib.request.Request("http://127.0.0.1:%d/v1/jobs?%s" % (port, a.query), data=body,
                                     headers={"Content-Type": "text/plain"})
        try:
            with urllib.request.urlopen(req, timeout=60) as r:
                codes[r.status] = codes.get(r.status, 0) + 1
                ids.append(json.loads(r.read())["id"])
        except urllib.error.HTTPError as e:
            codes[e.code] = codes.get(e.code, 0) + 1
    peak, running_max, waiting_max = start_rss, 0, 0
    outcomes = {}
    last_poll = 0
    while time.monotonic() - t0 < a.timeout:
        peak = max(peak, rss_kb(d.pid))
        running_max = max(running_max, metric(port, "rayd_jobs_running"))
        waiting_max = max(waiting_max, metric(port, "rayd_jobs_waiting_memory"))
        if time.monotonic() - last_poll > 1:
            last_poll = time.monotonic()
            ended = metric(port, 'rayd_jobs_total{outcome="done"}') + metric(
                port, 'rayd_jobs_total{outcome="failed"}') + metric(port, 'rayd_jobs_total{outcome="cancelled"}')
            if ended >= len(ids):
                break
        time.sleep(0.1)
    for o in ("done", "failed", "cancelled"):
        outcomes[o] = int(metric(port, 'rayd_jobs_total{outcome="%s"}' % o))
    hwm = rss_kb(d.pid, "VmHWM")
    budget = metric(port, "rayd_memory_budget_bytes")
    d.send_signal(signal.SIGTERM)
    rc = d.wait(timeout=60)
    print(json.dumps({
        "jobs": a.jobs, "query": a.query, "answers": codes, "budget_mib": round(budget / 2**20),
        "start_rss_mib": round(start_rss / 1024), "peak_rss_mib": round(peak / 1024),
        "vmhwm_mib": round(hwm / 1024), "max_running": int(running_max), "max_waiting_memory": int(waiting_max),
        "outcomes": outcomes, "seconds": round(time.monotonic() - t0, 1), "exit": rc}))
    return 0 if rc == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
