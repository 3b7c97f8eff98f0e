"""Section 5, HTTP: POST /v1/render of scenes/phong.cfg under wrk at each
connection count, rayd against bench/bare_mhd.c, a libmicrohttpd server with
rayd's flags that answers the same PNG bytes and does nothing else: the
HTTP ceiling of this machine. rayd and bare_mhd take turns; after each rayd
run the driver waits until /metrics shows no job queued or running."""
import os
import subprocess

from .. import measure

TITLE = "POST /v1/render under wrk, rayd against bare libmicrohttpd"
TOOLS = ("wrk", "cc", "pkg-config")

SIZES = ((64, 64), (640, 480))


def build_bare(ctx):
    flags = subprocess.run(["pkg-config", "--cflags", "--libs", "libmicrohttpd"], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE)
    if flags.returncode != 0:
        raise measure.Failed("pkg-config knows no libmicrohttpd: %s" % flags.stderr.decode().strip())
    binary = ctx.path("bare_mhd")
    measure.run(["cc", "-O2", "bench/bare_mhd.c"] + flags.stdout.decode().split() + ["-o", binary], cwd=ctx.root,
                what="cc bench/bare_mhd.c")
    return binary


def run(ctx):
    bare = build_bare(ctx)
    body_path = os.path.join(ctx.root, "scenes", "phong.cfg")
    with open(body_path, "rb") as f:
        body = f.read()
    queue = max(64, 2 * max(ctx.http_conc))
    rows, sizes = [], []
    with measure.Server(measure.rayd_serve_cmd(ctx.rayd, "--queue", str(queue)), ctx.path("rayd-http.log")) as rd:
        for w, h in SIZES:
            query = "/v1/render?width=%d&height=%d" % (w, h)
            png = ctx.path("phong-%dx%d.png" % (w, h))
            measure.rayd_render(ctx.rayd, "scenes/phong.cfg", png, w, h, ctx.cpus, cwd=ctx.root)
            with open(png, "rb") as f:
                want = f.read()
            status, headers, got, _ = measure.request(rd.url(query), "POST", body, "text/plain")
            if status != 200 or got != want:
                raise measure.Failed("rayd serve's answer to POST %s (status %d) is not the bytes of rayd "
                                     "render's PNG" % (query, status))
            sizes.append({"size": [w, h], "png_bytes": len(want),
                          "render_ms": float(headers.get("x-rayd-render-ms", "nan"))})
            # bare_mhd answers the PNG rayd makes for this very request.
            with measure.Server([bare, png, "{port_file}", "2"], ctx.path("bare-%dx%d.log" % (w, h))) as bm:
                for c in ctx.http_conc:
                    print("  wrk %dx%d -c %d: rayd, bare_mhd ..." % (w, h, c), flush=True)
                    r = measure.wrk(ctx.work, rd.url(query), body_path, c, ctx.http_secs)
                    idle = measure.wait_idle(rd)
                    b = measure.wrk(ctx.work, bm.url(query), body_path, c, ctx.http_secs)
                    rows.append({"size": [w, h], "connections": c, "rayd": r, "bare": b, "rayd_idle_after": idle})
    return {"settings": {"seconds": ctx.http_secs, "connections": ctx.http_conc, "queue": queue,
                         "render_threads": ctx.cpus, "bare_threads": 2},
            "sizes": sizes, "rows": rows, "rayd_exit": rd.rc}
