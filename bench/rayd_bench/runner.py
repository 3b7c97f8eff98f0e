"""The benchmark driver: options, the machine, the sections, results.json.

    python3 -m rayd_bench [--only SECTION,...] [--runs N] [--quick] ...

(from bench/, or with bench/ on PYTHONPATH). Each section returns a record
of every run with its raw numbers; the runner writes them with the machine,
the load average before and after, and the git commit to
build/bench/results.json after each section, then prints the tables
(report.py) and exits 1 if a section failed.
"""
import argparse
import datetime
import json
import os
import platform
import shutil
import signal
import subprocess
import sys
import tempfile
import time

from . import measure, report
from .sections import SECTIONS

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FOUNDATION = "8745562"
EMBREE_SCENES = ("three", "spheres10k", "bumpy1m")
PRIM_COUNTS = (100, 1000, 10000, 100000, 1000000)


def _list(text, conv=str):
    return [conv(x) for x in text.replace(" ", ",").split(",") if x]


def _size(text):
    try:
        w, h = text.lower().split("x")
        w, h = int(w), int(h)
    except ValueError:
        raise argparse.ArgumentTypeError("expected WxH, got '%s'" % text)
    if w < 1 or h < 1:
        raise argparse.ArgumentTypeError("expected a positive WxH, got '%s'" % text)
    return w, h


def _positive(text):
    try:
        v = int(text)
    except ValueError:
        v = 0
    if v < 1:
        raise argparse.ArgumentTypeError("expected a positive integer, got '%s'" % text)
    return v


def _positives(text):
    try:
        v = _list(text, int)
    except ValueError:
        v = []
    if not v or min(v) < 1:
        raise argparse.ArgumentTypeError("expected positive integers separated by commas, got '%s'" % text)
    return v


def parser():
    ap = argparse.ArgumentParser(
        prog="python3 -m rayd_bench",
        description="rayd's benchmark: rayd against POV-Ray, threads, large scenes, rayd against Embree on the "
                    "same rays, rays/s against the primitive count, the foundation commit, "
                    "HTTP load, overload, mixed jobs, convergence and equal time. Sections: "
                    + ", ".join(SECTIONS) + ".")
    ap.add_argument("--rayd", default=os.path.join(ROOT, "build", "rayd"), help="the rayd binary (build/rayd)")
    ap.add_argument("--only", type=_list, default=None, metavar="SECTION[,SECTION]",
                    help="run only these sections (default: every one)")
    ap.add_argument("--skip", type=_list, default=[], metavar="SECTION[,SECTION]", help="leave these out")
    ap.add_argument("--runs", type=_positive, default=None,
                    help="runs per configuration, best kept (default 3; 1 with --quick)")
    ap.add_argument("--quick", action="store_true",
                    help="small sizes and short loads, to check the driver itself in a minute or two; "
                         "its results are not for bench/README.md")
    ap.add_argument("--threads", type=_positives, default=[1, 2], metavar="N[,N]",
                    help="thread counts of scenes and large (default 1,2; speed-ups against the first)")
    ap.add_argument("--scenes", type=_list, default=["diffuse", "phong"], metavar="NAME[,NAME]",
                    help="scenes/NAME.cfg with bench/NAME.pov for the scenes section (default diffuse,phong)")
    ap.add_argument("--large", type=_list, default=["spheres10k", "knot1m"], metavar="NAME[,NAME]",
                    help="generated scenes of the large section: spheres10k, knot1m (default both)")
    ap.add_argument("--large-size", type=_size, default=None, metavar="WxH", help="their image size (960x540)")
    ap.add_argument("--embree-scenes", type=_list, default=list(EMBREE_SCENES), metavar="NAME[,NAME]",
                    help="scenes of the embree section: %s (default all)" % ", ".join(EMBREE_SCENES))
    ap.add_argument("--prim-counts", type=_positives, default=list(PRIM_COUNTS), metavar="N[,N]",
                    help="triangle counts of the primitives section, of %s (default all; --quick: up to 10000)"
                         % ",".join(map(str, PRIM_COUNTS)))
    ap.add_argument("--embree-trace", default=os.path.join(ROOT, "build", "bench", "embree_trace"),
                    help="the Embree harness of embree and primitives (build/bench/embree_trace)")
    ap.add_argument("--base", default=FOUNDATION, metavar="COMMIT",
                    help="the commit of the base section (default the foundation, %s)" % FOUNDATION)
    ap.add_argument("--http-secs", type=_positive, default=None, help="length of each wrk run (10)")
    ap.add_argument("--http-conc", type=_positives, default=None, metavar="N[,N]",
                    help="wrk connection counts (1,8,64)")
    ap.add_argument("--overload-secs", type=_positive, default=None, help="length of the hey run (10)")
    ap.add_argument("--eq-size", type=_size, default=None, metavar="WxH", help="equal section's size (320x240)")
    ap.add_argument("--eq-threads", type=_positive, default=1, help="equal section's render threads (1)")
    ap.add_argument("--eq-ref-samples", type=_positive, default=None, help="rayd's reference samples (512)")
    ap.add_argument("--out-dir", default=os.path.join(ROOT, "build", "bench-out"),
                    help="where converge writes its SVG and CSV files (build/bench-out)")
    ap.add_argument("--results", default=os.path.join(ROOT, "build", "bench", "results.json"),
                    help="the results file (build/bench/results.json)")
    ap.add_argument("--keep", action="store_true", help="keep the images, logs and generated scenes")
    return ap


class Context:
    """What every section sees: the options, paths, and shared measurements."""

    def __init__(self, a, work):
        q = a.quick
        self.quick = q
        self.rayd = os.path.abspath(a.rayd)
        self.root = ROOT
        self.work = work
        self.runs = a.runs or (1 if q else 3)
        self.threads = a.threads
        self.scenes = a.scenes
        self.size = (192, 108) if q else (1920, 1080)
        self.large = a.large
        self.large_size = a.large_size or ((192, 108) if q else (960, 540))
        self.embree_scenes = a.embree_scenes
        self.prim_counts = a.prim_counts
        self.embree_trace = os.path.abspath(a.embree_trace)
        self.keep = a.keep
        self.base = a.base
        self.http_secs = a.http_secs or (1 if q else 10)
        self.http_conc = a.http_conc or ([1, 4] if q else [1, 8, 64])
        self.overload_secs = a.overload_secs or (2 if q else 10)
        self.eq_size = a.eq_size or ((80, 60) if q else (320, 240))
        self.eq_threads = a.eq_threads
        self.eq_ref_samples = a.eq_ref_samples or (32 if q else 512)
        self.out_dir = os.path.abspath(a.out_dir)
        self.cpus = os.cpu_count() or 1
        self._pov_overhead = None

    def path(self, *parts):
        return os.path.join(self.work, *parts)

    def povray_overhead(self):
        """Measured once per run, for every section that runs POV-Ray."""
        if self._pov_overhead is None:
            self._pov_overhead = measure.povray_overhead(self.work, self.runs)
        return self._pov_overhead

    def settings(self):
        return {k: v for k, v in vars(self).items() if not k.startswith("_") and k not in ("root", "work")}


def machine():
    cpu = platform.processor() or "?"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = None
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    mem = int(line.split()[1]) * 1024
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "memory_bytes": mem, "kernel": platform.release(),
            "python": platform.python_version()}


def git_commit():
    def git(*args):
        r = subprocess.run(["git", "-C", ROOT] + list(args), stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        return r.stdout.decode().strip() if r.returncode == 0 else None
    commit = git("rev-parse", "HEAD")
    dirty = git("status", "--porcelain", "--untracked-files=no")
    return {"commit": commit, "short": commit[:7] if commit else None, "local_changes": bool(dirty)}


def _on_signal(signum, frame):
    # Unwinds through every `with Server(...)` and `finally`, so servers
    # and the base section's worktree go with the driver.
    raise SystemExit(128 + signum)


def write_results(path, results):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(results, f, indent=1)
        f.write("\n")
    os.replace(tmp, path)


def main(argv=None):
    a = parser().parse_args(argv)
    names = a.only if a.only is not None else list(SECTIONS)
    for n in names + a.skip:
        if n not in SECTIONS:
            print("rayd_bench: unknown section '%s' (%s)" % (n, ", ".join(SECTIONS)), file=sys.stderr)
            return 2
    names = [n for n in SECTIONS if n in names and n not in a.skip]
    for s in a.large:
        if s not in ("spheres10k", "knot1m"):
            print("rayd_bench: --large: unknown scene '%s' (spheres10k, knot1m)" % s, file=sys.stderr)
            return 2
    for s in a.embree_scenes:
        if s not in EMBREE_SCENES:
            print("rayd_bench: --embree-scenes: unknown scene '%s' (%s)" % (s, ", ".join(EMBREE_SCENES)),
                  file=sys.stderr)
            return 2
    for c in a.prim_counts:
        if c not in PRIM_COUNTS:
            print("rayd_bench: --prim-counts: %d is not one of %s" % (c, ",".join(map(str, PRIM_COUNTS))),
                  file=sys.stderr)
            return 2
    if not (os.path.isfile(a.rayd) and os.access(a.rayd, os.X_OK)):
        print("rayd_bench: %s: not an executable file (build it with make)" % a.rayd, file=sys.stderr)
        return 2
    missing = sorted({t for n in names for t in SECTIONS[n].TOOLS if shutil.which(t) is None})
    if missing:
        print("rayd_bench: not found: %s (sh deploy/deps.sh bench installs them), needed by: %s"
              % (", ".join(missing), ", ".join(n for n in names if set(SECTIONS[n].TOOLS) & set(missing))),
              file=sys.stderr)
        return 2
    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, _on_signal)

    # POV-Ray's I/O restrictions (/etc/povray/3.7/povray.conf) allow
    # writing under /tmp, so the scratch folder is there whatever TMPDIR says.
    work = tempfile.mkdtemp(prefix="rayd-bench.", dir="/tmp")
    ctx = Context(a, work)
    results = {
        "started": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "quick": ctx.quick, "machine": machine(), "git": git_commit(), "rayd": ctx.rayd,
        "load_before": measure.loadavg(), "settings": ctx.settings(), "sections": {},
    }
    print("rayd bench%s: %s; %d cores, load average %s; commit %s%s" % (
        " (--quick)" if ctx.quick else "", ", ".join(names), ctx.cpus,
        " ".join("%.2f" % x for x in results["load_before"]), results["git"]["short"],
        " (with local changes)" if results["git"]["local_changes"] else ""), flush=True)
    failed = []
    try:
        for n in names:
            mod = SECTIONS[n]
            print("== %s: %s; load average %s" % (n, mod.TITLE, " ".join("%.2f" % x for x in measure.loadavg())),
                  flush=True)
            t0 = time.monotonic()
            rec = {"load_before": measure.loadavg()}
            try:
                rec.update(mod.run(ctx))
            except measure.Failed as e:
                rec["error"] = str(e)
                failed.append(n)
                print("  FAILED: %s" % e, file=sys.stderr, flush=True)
            rec["load_after"] = measure.loadavg()
            rec["seconds"] = round(time.monotonic() - t0, 1)
            rec["quick"] = ctx.quick
            rec["git"] = results["git"]
            rec["started"] = results["started"]
            rec["runs_per_config"] = ctx.runs
            results["sections"][n] = rec
            results["load_after"] = measure.loadavg()
            write_results(a.results, results)
            if "error" not in rec:
                try:
                    print(report.section_text(n, rec, results), flush=True)
                except (KeyError, TypeError, ValueError, ZeroDivisionError) as e:
                    # The figures are in results.json; only their table failed.
                    failed.append(n)
                    print("  FAILED to print the table: %r" % e, file=sys.stderr, flush=True)
    finally:
        if a.keep:
            print("rayd_bench: images and logs kept in %s" % work, file=sys.stderr)
        else:
            shutil.rmtree(work, ignore_errors=True)
    print("results: %s; load average at the end %s" % (
        os.path.relpath(a.results), " ".join("%.2f" % x for x in measure.loadavg())))
    if failed:
        print("rayd_bench: failed: %s" % ", ".join(failed), file=sys.stderr)
        return 1
    return 0
