#!/usr/bin/env python3
"""`rayd serve --threads N` renders on N threads, whatever is in flight.

For N = 1 and N = 2, one daemon (127.0.0.1, a port it picks, its own SQLite
store) is given a long synchronous render (POST /v1/render) and a long
stored job (POST /v1/jobs); once both run (the stored job `running`, no job
waiting in the queue while the synchronous render has no answer, so it has
started), a grade of a student's image (POST /v1/grade), a batch grade of
three images (POST /v1/grade/batch) and a code grade (POST /v1/grade/code
of tests/codegrade/students/phong_ok.h) are sent, and the daemon's own CPU
time (utime + stime of /proc/PID/stat: every thread of it, not its
sandboxes' processes, which are children) is read then and WINDOW_S later,
with the five in flight. Both renders must still be running at the end
(the stored job `running`, the synchronous render not answered), so the
window cannot be one where nothing rendered, and the stored job's progress
must move (within 30 s: a loaded machine may starve the daemon, which only
lowers what it measures). Then the renders are cancelled, and the grades
must pass (the batch: three rows). The bound:

    CPU seconds <= N x wall seconds x 1.1 + SLACK_S

The 1.1 covers reading the clock and the CPU time at slightly different
moments and the CPU time's 10 ms ticks. SLACK_S (0.3 s over the 4 s
window, 7.5% of one core) is for the threads that are not render threads:
the HTTP threads answering this test's polls and moving the grades' bytes,
the watchdog (every 20 ms), the connection reaper (every 100 ms), the
farm's watcher and its store waits (SQLite's data_version looked at every
10 ms). Measured here: an idle daemon used 0.04 s of CPU in 4 s, 0.05 s
polled ten times a second (as the batch is in the window); the three grades
alone cost the daemon 0.16 s, wherever they run. RAYD_TEST_SLOW=3 (a
sanitizer build) makes SLACK_S as many times larger. A render thread beyond N
adds up to a core: with one render thread for the synchronous renders and
another for the stored jobs, N = 1 measures about 2 x wall.

The bound is an upper one: a loaded machine only lowers what the daemon
gets, so load cannot fail it. But load can hide a thread too many (a
daemon given half a core cannot show two), and on two cores N = 2 cannot
exceed 2 x wall at all. So the CPU time of each thread is read too
(/proc/PID/task/TID/stat), and the same bound is asserted against what the
N busiest threads got instead of the wall time:

    CPU seconds <= (CPU seconds of the N busiest threads) x 1.1 + SLACK_S

which implies the first, does not depend on the machine's load or cores,
and fails whenever threads beyond N render (each takes its share of the
cores, however small). The code grader's sandbox is part of the mix: where
it cannot start (no bubblewrap, no user namespaces), the test says so and
fails.

Usage: RAYD=build/rayd /usr/bin/python3 tests/integration/cpu_test.py
(from the repository root). The daemons are stopped by their pid; the run
is bounded by BOUND_S seconds (times RAYD_TEST_SLOW, default 1). Prints the
measured CPU of each N and `cpu: N passed, M failed`; exits 1 on a
failure, keeping the temporary folder (logs) and naming it.
"""
import concurrent.futures
import json
import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from rayd_http import RAYD, Checks, Daemon, answered, form_parts, metric_value, png, raw_post  # noqa: E402
import stored_jobs  # noqa: E402
from stored_jobs import Abort, status_json  # noqa: E402

check = Checks("cpu")
SLOW = float(os.environ.get("RAYD_TEST_SLOW", "1"))
BOUND_S = int(240 * SLOW)
WINDOW_S = 4.0
FACTOR = 1.1
# Under sanitizers (RAYD_TEST_SLOW=3) every thread costs as many times more.
SLACK_S = 0.3 * SLOW
TOKEN = "cpu-test-token-0123456789abcdef"
# Each takes minutes on a core here: still running when the window ends on
# a machine many times as fast; cancelled once measured. The stored job's
# tiles (--store-tile 8, 4800 of them) take about 40 ms each here, so its
# progress moves many times in a window.
LONG = ("area_light.cfg", "width=640&height=480&samples=256")
STORE_TILE = 8
CODE = "tests/codegrade/students/phong_ok.h"
CLK_TCK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid):
    """utime + stime of the process (all its threads, living and ended;
    not its children), in seconds."""
    with open("/proc/%d/stat" % pid) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK


def thread_seconds(pid):
    """{thread id: utime + stime} of the process's living threads."""
    out = {}
    for tid in os.listdir("/proc/%d/task" % pid):
        try:
            with open("/proc/%d/task/%s/stat" % (pid, tid)) as f:
                fields = f.read().rsplit(")", 1)[1].split()
            out[tid] = (int(fields[11]) + int(fields[12])) / CLK_TCK
        except (OSError, IndexError, ValueError):
            pass  # it ended meanwhile
    return out


def call(d, method, path, body=None, headers=None, timeout=60):
    try:
        return d.request(method, path, body=body, headers=headers, timeout=timeout * SLOW)
    except OSError as e:
        rc = d.proc.poll()
        raise Abort("%s %s: %s%s" % (method, path.split("?")[0], e,
                                     "" if rc is None else " (the daemon exited %d): %s" % (rc, d.text()[-800:])))


def job_status(d, jid):
    return status_json(*call(d, "GET", "/v1/jobs/" + jid)[::2])


def queue_depth(d):
    st, _, body = call(d, "GET", "/metrics")
    return metric_value(body, "rayd_queue_depth") if st == 200 else None


def grade(d, image):
    body, ct = form_parts([("assignment", None, b"phong"), ("student", None, b"ann"), ("image", "ann.png", image)])
    st, _, b = call(d, "POST", "/v1/grade", body=body, headers={"Content-Type": ct}, timeout=120)
    return st, b


def batch(d, images):
    parts = [("assignment", None, b"phong")] + [("image", name + ".png", data) for name, data in images.items()]
    body, ct = form_parts(parts)
    st, _, b = call(d, "POST", "/v1/grade/batch", body=body,
                    headers={"Content-Type": ct, "Authorization": "Bearer " + TOKEN}, timeout=120)
    if st != 202:
        return st, b
    bid = json.loads(b).get("id", "")
    deadline = time.time() + 120 * SLOW
    while time.time() < deadline:
        st, _, b = call(d, "GET", "/v1/grade/batch/" + bid, headers={"Authorization": "Bearer " + TOKEN})
        if st != 200 or json.loads(b).get("status") != "running":
            return st, b
        time.sleep(0.1)
    return 0, b"the batch was still running after %d s" % (120 * SLOW)


def code_grade(d):
    with open(CODE, "rb") as f:
        text = f.read()
    body, ct = form_parts([("assignment", None, b"phong"), ("student", None, b"ann"),
                           ("source", "PhongMaterial.h", text)])
    st, _, b = call(d, "POST", "/v1/grade/code", body=body, headers={"Content-Type": ct}, timeout=240)
    return st, b


def verdict(st, b):
    try:
        return st, json.loads(b)
    except ValueError:
        return st, {"raw": b[:300]}


def measure(tmp, n, student):
    """One daemon with --threads n under the mix: its CPU seconds over the
    window, and the window's wall seconds."""
    folder = os.path.join(tmp, "threads-%d" % n)
    os.makedirs(folder)
    tokens = os.path.join(folder, "tokens")
    with open(tokens, "w") as f:
        f.write(TOKEN + "\n")
    flags = ["--threads", str(n), "--instructor-tokens", tokens, "--data-dir", os.path.join(folder, "data"),
             "--job-timeout-ms", "0", "--drain-ms", "2000", "--store-tile", str(STORE_TILE),
             # The compiler shares the cores with the two renders (and a
             # loaded machine): its time is not what is measured here.
             "--code-compile-seconds", "300", "--code-run-seconds", "300"]
    try:
        d = Daemon(folder, flags)
    except RuntimeError as e:
        raise Abort("rayd serve %s did not start: %s" % (" ".join(flags), e))
    pool = concurrent.futures.ThreadPoolExecutor(3)
    sync = None
    try:
        st, _, b = call(d, "GET", "/readyz")
        why = (json.loads(b).get("unavailable") or {}).get("code_grading") if st == 200 else "readyz %d" % st
        check(not why, "N=%d: the code grader's sandbox cannot start on this machine (%s): the mix has no code "
              "grade, so this test cannot hold the daemon to its threads under it" % (n, why))
        with open(os.path.join("scenes", LONG[0]), "rb") as f:
            scene = f.read()
        # The two long renders, then (once both run) the three grades, so
        # that the window has all five in flight.
        sync = raw_post(d.port, "/v1/render?" + LONG[1], scene, {"Content-Type": "text/x-rayd-cfg"})
        st, _, b = call(d, "POST", "/v1/jobs?" + LONG[1], body=scene, headers={"Content-Type": "text/x-rayd-cfg"})
        jid = json.loads(b).get("id") if st == 202 else None
        if not jid:
            raise Abort("N=%d: POST /v1/jobs answered %d %r" % (n, st, b[:300]))
        # Both renders running: the stored job says so, and no job waits
        # in the queue while the synchronous render has no answer (so it
        # has started).
        deadline, s, depth = time.time() + 60 * SLOW, {}, None
        while time.time() < deadline:
            s, depth = job_status(d, jid), queue_depth(d)
            if s.get("status") == "running" and depth == 0 and not answered(sync):
                break
            if answered(sync) or s.get("status") not in ("queued", "running"):
                break
            time.sleep(0.05)
        if not (s.get("status") == "running" and depth == 0 and not answered(sync)):
            raise Abort("N=%d: the two renders were not both running after %.0f s: the stored job %s, queue depth "
                        "%s, the synchronous render %s" % (n, 60 * SLOW, s.get("status"), depth,
                                                           "answered" if answered(sync) else "waiting"))
        progress0 = s.get("progress", 0)
        grades = {"the grade": pool.submit(grade, d, student),
                  "the batch grade": pool.submit(batch, d, {"ann": student, "bob": png(320, 240, lambda x, y: (0, 0, 0)),
                                                            "cy": png(32, 24, lambda x, y: (9, 9, 9))}),
                  "the code grade": pool.submit(code_grade, d)}
        th0, c0, t0 = thread_seconds(d.pid), cpu_seconds(d.pid), time.monotonic()
        time.sleep(WINDOW_S)
        c1, t1, th1 = cpu_seconds(d.pid), time.monotonic(), thread_seconds(d.pid)
        # Which threads used it: under load each gets less, but the busy
        # ones stay apart from the idle ones.
        by_thread = sorted((v - th0.get(tid, 0.0) for tid, v in th1.items()), reverse=True)
        s = job_status(d, jid)
        running = s.get("status") == "running" and not answered(sync)
        check(running, "N=%d: a render ended within the window: the stored job %s, the synchronous render %s" %
              (n, s.get("status"), "answered" if answered(sync) else "waiting"))
        cpu, wall = c1 - c0, t1 - t0
        # It renders: its progress moves (a loaded machine may starve it
        # for a while, which only lowers the CPU figure).
        moved, deadline = s, time.time() + 30 * SLOW
        while moved.get("status") == "running" and moved.get("progress", 0) <= progress0 and time.time() < deadline:
            time.sleep(0.1)
            moved = job_status(d, jid)
        check(moved.get("progress", 0) > progress0, "N=%d: the stored job is %s and its progress did not move from "
              "%s in %.0f s: nothing renders it" % (n, moved.get("status"), progress0, 30 * SLOW + WINDOW_S))
        bound = n * wall * FACTOR + SLACK_S
        print("cpu: --threads %d: %.2f s of CPU in %.2f s (%.2f cores; the bound %.2f s = %d x %.2f x %.1f + %.2f); "
              "the stored job at %.0f%%, then %.0f%%" % (n, cpu, wall, cpu / wall, bound, n, wall, FACTOR, SLACK_S,
                                                         100 * progress0, 100 * s.get("progress", 0)), flush=True)
        top = sum(by_thread[:n])
        print("cpu: --threads %d: %d threads, the busiest used %s s; all but the %d busiest %.2f s" %
              (n, len(by_thread), " ".join("%.2f" % x for x in by_thread[:6]), n, cpu - top), flush=True)
        check(cpu <= bound, "N=%d: the daemon used %.2f s of CPU in %.2f s (%.2f cores), over %.2f s: more than "
              "--threads %d render threads" % (n, cpu, wall, cpu / wall, bound, n))
        check(cpu <= top * FACTOR + SLACK_S, "N=%d: the daemon used %.2f s of CPU, its %d busiest thread(s) %.2f s: "
              "the others used %.2f s, over %.1f x theirs + %.2f s: threads beyond --threads %d rendered" %
              (n, cpu, n, top, cpu - top, FACTOR - 1, SLACK_S, n))
        # The mix ends: the two long renders cancelled, the grades answered.
        st, _, _ = call(d, "DELETE", "/v1/jobs/" + jid)
        check(st == 200, "N=%d: DELETE of the stored job: %d" % (n, st))
        sync.close()
        sync = None
        for what, fut in grades.items():
            st, v = verdict(*fut.result(timeout=300 * SLOW))
            if what == "the code grade" and st == 503:
                check(False, "N=%d: the code grade: 503 %s: the sandbox is unavailable on this machine" %
                      (n, (v.get("error") or {}).get("message")))
            elif what == "the batch grade":
                rows = v.get("results") or []
                check(st == 200 and v.get("status") == "done" and len(rows) == 3,
                      "N=%d: %s: %d %s" % (n, what, st, str(v)[:300]))
            else:
                check(st == 200 and v.get("pass") is True, "N=%d: %s: %d %s" % (n, what, st, str(v)[:300]))
    finally:
        if sync:
            sync.close()
        pool.shutdown(wait=False, cancel_futures=True)
        rc = d.stop()
    check(rc == 0, "N=%d: the daemon exited %s after SIGTERM" % (n, rc))
    return cpu, wall


def main():
    tmp = tempfile.mkdtemp(prefix="rayd-cpu-")

    def run():
        out = os.path.join(tmp, "student.png")
        subprocess.run([RAYD, "render", "scenes/assignments/phong.cfg", "-o", out, "--quiet"], check=True,
                       capture_output=True, timeout=120 * SLOW)
        with open(out, "rb") as f:
            student = f.read()
        figures = []
        for n in (1, 2):
            try:
                cpu, wall = measure(tmp, n, student)
                figures.append("--threads %d: %.2f cores" % (n, cpu / wall))
            except Abort as e:
                check(False, str(e))
        if os.cpu_count() and os.cpu_count() <= 2:
            print("cpu: this machine has %d cores: --threads 2 cannot exceed N x wall here; the bound by its "
                  "busiest threads still tells" % os.cpu_count())
        print("cpu: %s" % "; ".join(figures))

    # measure() stops its daemon whatever happens.
    return stored_jobs.bounded_run(check, "cpu", BOUND_S, run, [], [tmp], [])


if __name__ == "__main__":
    sys.exit(main())
