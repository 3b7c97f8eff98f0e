"""Section 7, a small job behind a large one: sequential 64x64 sync renders
of scenes/phong.cfg alone, then the same while one async 640x480 job of
scenes/area_light.cfg at 64 samples per pixel runs; the large job's state
(its JSON status) is read before each small render."""
import json
import os
import time

from .. import measure

TITLE = "small sync renders behind one large async job"
TOOLS = ()


def run(ctx):
    n = 5 if ctx.quick else 20
    big_w, big_h, big_spp = (160, 120, 16) if ctx.quick else (640, 480, 64)
    with open(os.path.join(ctx.root, "scenes", "phong.cfg"), "rb") as f:
        small_body = f.read()
    with open(os.path.join(ctx.root, "scenes", "area_light.cfg"), "rb") as f:
        big_body = f.read()
    small_q = "/v1/render?width=64&height=64"

    with measure.Server(measure.rayd_serve_cmd(ctx.rayd, "--queue", "64"), ctx.path("rayd-mixed.log")) as rd:
        def small():
            status, _, _, secs = measure.request(rd.url(small_q), "POST", small_body, "text/plain", timeout=120)
            return {"status": status, "ms": secs * 1000.0}

        print("  %d small renders alone ..." % n, flush=True)
        small()
        small()
        alone = [small() for _ in range(n)]
        print("  %d small renders behind the large job ..." % n, flush=True)
        status, _, data, _ = measure.request(
            rd.url("/v1/jobs?width=%d&height=%d&samples=%d" % (big_w, big_h, big_spp)), "POST", big_body,
            "text/plain", timeout=30)
        if status != 202:
            raise measure.Failed("POST /v1/jobs of area_light.cfg answered %d: %s" % (status, data[:300]))
        job = json.loads(data)["id"]
        t0 = time.monotonic()
        behind = []
        for _ in range(n):
            st = measure.get_json(rd.url("/v1/jobs/" + job))["status"]
            s = small()
            s.update(big_status=st, at_ms=(time.monotonic() - t0) * 1000.0)
            behind.append(s)
        deadline = time.monotonic() + 120
        info = measure.get_json(rd.url("/v1/jobs/" + job))
        while info["status"] not in ("done", "failed", "cancelled") and time.monotonic() < deadline:
            time.sleep(0.2)
            info = measure.get_json(rd.url("/v1/jobs/" + job))
        seen_ms = (time.monotonic() - t0) * 1000.0
        if info["status"] not in ("done", "failed", "cancelled"):
            measure.request(rd.url("/v1/jobs/" + job), "DELETE", timeout=10)
    ok = [s["ms"] for s in alone if s["status"] == 200], [s["ms"] for s in behind if s["status"] == 200]
    return {"settings": {"small": n, "small_size": [64, 64], "big_size": [big_w, big_h], "big_samples": big_spp},
            "alone": alone, "behind": behind,
            "summary": {"alone_p50": measure.percentile(ok[0], 50), "alone_p99": measure.percentile(ok[0], 99),
                        "behind_p50": measure.percentile(ok[1], 50), "behind_p99": measure.percentile(ok[1], 99),
                        "behind_first": behind[0]["ms"] if behind else None,
                        "overlapping": sum(1 for s in behind if s["big_status"] in ("queued", "running")),
                        "not_200": sum(1 for s in alone + behind if s["status"] != 200)},
            "big": {"status": info["status"], "elapsed_ms": info.get("elapsed_ms"),
                    "queued_ms": info.get("queued_ms"), "seen_ended_ms": seen_ms},
            "rayd_exit": rd.rc}
