"""Table 4, "leave out what a scene does not need": scenes/diffuse.cfg at
1920x1080 on 1 thread, this rayd against rayd built from the foundation
commit in a temporary git worktree. The diffuse scene uses none of what came
after the foundation (BVH, meshes, textures, statistics, jobs), so it should
render about as fast; a ratio well above 1 means it pays for them.

The foundation's rayd predates --stats-format json: its render time is read
from its one statistics line (time_ms=...). That binary cannot change, so
this is the one place the driver reads rayd's text; everything of this rayd
comes from its JSON."""
import os
import re
import shutil
import subprocess

from .. import measure

TITLE = "scenes/diffuse.cfg, this rayd against rayd at the foundation commit"
TOOLS = ("git", "make", "cc", "pkg-config")


def git(ctx, *args, check=True):
    return measure.run(["git", "-C", ctx.root] + list(args), check=check, what="git " + args[0])


def build_base(ctx):
    """Builds rayd at ctx.base in a worktree that is removed at once;
    returns (binary path, None) or (None, why not)."""
    r = git(ctx, "rev-parse", "--verify", "--quiet", ctx.base + "^{commit}", check=False)
    if r.rc != 0:
        return None, "%s is not a commit of %s" % (ctx.base, ctx.root)
    src = ctx.path("base-src")
    binary = ctx.path("rayd-base")
    try:
        git(ctx, "worktree", "add", "--detach", src, ctx.base)
        # make bench's own variables must not leak into this build.
        env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL")}
        b = measure.run(["make", "-C", src, "-j2", "BUILD=build", "build/rayd"], env=env, check=False)
        if b.rc != 0:
            return None, "building rayd at %s failed:\n  %s" % (ctx.base, "\n  ".join(b.tail(10)))
        shutil.copy2(os.path.join(src, "build", "rayd"), binary)
    finally:
        if os.path.isdir(src):
            if git(ctx, "worktree", "remove", "--force", src, check=False).rc != 0:
                shutil.rmtree(src, ignore_errors=True)
                git(ctx, "worktree", "prune", check=False)
    return binary, None


def legacy_time_ms(r):
    m = re.findall(r"^render: .* time_ms=([0-9.]+)", r.stderr, re.M)
    if not m:
        raise measure.Failed("no statistics line from the foundation's rayd:\n  %s" % "\n  ".join(r.tail()))
    return float(m[-1])


def run(ctx):
    w, h = ctx.size
    print("  building rayd at %s in a git worktree ..." % ctx.base, flush=True)
    binary, why = build_base(ctx)
    if binary is None:
        return {"settings": {"base": ctx.base}, "skipped": why}
    rev = subprocess.run(["git", "-C", ctx.root, "rev-parse", "--short", ctx.base], stdout=subprocess.PIPE,
                         stderr=subprocess.DEVNULL).stdout.decode().strip()
    print("  diffuse, 1 thread, %d run(s) each ..." % ctx.runs, flush=True)
    base_runs, cur_runs = [], []
    base_png, cur_png = ctx.path("base.png"), ctx.path("current.png")
    for _ in range(ctx.runs):
        r = measure.run([binary, "render", "scenes/diffuse.cfg", "-o", base_png, "--width", str(w), "--height",
                         str(h), "--threads", "1"], cwd=ctx.root, what="the foundation's rayd")
        base_runs.append(dict(r.record(), time_ms=legacy_time_ms(r)))
        r, st = measure.rayd_render(ctx.rayd, "scenes/diffuse.cfg", cur_png, w, h, 1, cwd=ctx.root)
        cur_runs.append(dict(r.record(), time_ms=st["time_ms"], stats=measure.stats_record(st)))
    best = measure.best
    return {"settings": {"base": ctx.base, "base_short": rev, "size": [w, h], "threads": 1, "runs": ctx.runs},
            "base": base_runs, "current": cur_runs,
            "best": {"base_render_ms": best(x["time_ms"] for x in base_runs),
                     "base_wall_ms": best(x["wall_ms"] for x in base_runs),
                     "current_render_ms": best(x["time_ms"] for x in cur_runs),
                     "current_wall_ms": best(x["wall_ms"] for x in cur_runs)},
            "images": measure.compare(ctx.rayd, base_png, cur_png)}
