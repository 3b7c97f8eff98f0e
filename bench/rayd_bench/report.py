"""The Markdown tables of bench/README.md, from results.json.

    python3 -m rayd_bench.report [--results FILE ...] [--readme bench/README.md] [--print] [--allow-quick]

The README keeps its hand-written prose; each table sits between
`<!-- generated:NAME -->` and `<!-- end -->`, and only those lines are
rewritten. With several results files, a section comes from the last file
that has it, so sections measured in separate runs can be combined. A
--quick run checks the driver and is not written to the README unless
--allow-quick says so. Every table ends with the run it came from.
"""
import argparse
import json
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def f(x, fmt="%.1f"):
    return "n/a" if x is None else fmt % x


def ratio(a, b, fmt="%.2f"):
    return "n/a" if a is None or not b else fmt % (a / b)


def n(x):
    return "n/a" if x is None else "{:,}".format(int(x))


def _numeric(cell):
    return re.fullmatch(r"[-+]?[0-9][0-9,]*(\.[0-9]+)?x?|n/a|", str(cell).strip()) is not None


def table(head, rows):
    """A Markdown table; columns of numbers are right-aligned."""
    right = [bool(rows) and all(_numeric(r[i]) for r in rows) for i in range(len(head))]
    out = ["| " + " | ".join(head) + " |", "|" + "|".join("---:" if r else "---" for r in right) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def provenance(sec):
    g = sec.get("git", {})
    lb, la = sec.get("load_before"), sec.get("load_after")
    return ("*Measured by `python3 -m rayd_bench` at commit `%s`%s, %s, %s run%s per configuration, "
            "load average %s before and %s after (1 min); the section took %s s.*" % (
                g.get("short"), " with local changes" if g.get("local_changes") else "", sec.get("started"),
                sec.get("runs_per_config"), "" if sec.get("runs_per_config") == 1 else "s",
                f(lb[0], "%.2f") if lb else "?", f(la[0], "%.2f") if la else "?", f(sec.get("seconds"), "%.0f"))
            + (" **--quick: sizes and loads cut down, not for comparison.**" if sec.get("quick") else ""))


def mrays(rays, ms):
    return None if rays is None or not ms else rays / ms / 1000.0


def speedups(rows, cols):
    """Speed-up of each later thread count over the first, per scene."""
    out = []
    first = {}
    for r in rows:
        if r["scene"] not in first:
            first[r["scene"]] = r
            continue
        a = first[r["scene"]]
        out.append(["%s, %d/%d threads" % (r["scene"], r["threads"], a["threads"])]
                   + [ratio(a["best"][k], r["best"][k]) + "x" for k in cols])
    return out


def images(c):
    return "%s of %s pixels differ, by at most %d" % (n(c["differing_pixels"]), n(c["pixels"]), c["max_diff"])


# ---------------------------------------------------------------- sections

def t_scenes(sec):
    rows = []
    for r in sec["rows"]:
        b = r["best"]
        pm = mrays(r["rays_povray"], b["povray_trace_ms"])
        # A results.json from before the rate took the job status's name has rays_per_s.
        rate = b["rayd_rays_per_second"] if "rayd_rays_per_second" in b else b["rayd_rays_per_s"]
        rows.append([r["scene"], r["threads"], f(b["rayd_wall_ms"]), f(b["rayd_render_ms"]),
                     f(rate / 1e6, "%.2f"), f(b["povray_wall_ms"]), f(b["povray_trace_ms"]),
                     f(pm, "%.2f"), ratio(b["rayd_wall_ms"], b["povray_wall_ms"]),
                     ratio(b["rayd_render_ms"], b["povray_trace_ms"])])
    w, h = sec["settings"]["size"]
    out = ["%dx%d, %s (`-A +Q9`); POV-Ray's start-up and shut-down on an empty scene: %s ms, part of each of "
           "its wall times." % (w, h, sec.get("povray", "POV-Ray"), f(sec.get("povray_overhead_ms"), "%.0f")), "",
           table(["scene", "threads", "rayd wall ms", "rayd render ms", "rayd Mrays/s", "POV-Ray wall ms",
                  "POV-Ray trace ms", "POV-Ray Mrays/s", "ratio wall", "ratio render"], rows)]
    sp = speedups(sec["rows"], ("rayd_wall_ms", "rayd_render_ms", "povray_wall_ms", "povray_trace_ms"))
    if sp:
        out += ["", table(["speed-up", "rayd wall", "rayd render", "POV-Ray wall", "POV-Ray trace"], sp)]
    seen, rr = set(), []
    for r in sec["rows"]:
        if r["scene"] in seen:
            continue
        seen.add(r["scene"])
        rr.append([r["scene"], n(r["camera_rays"]), n(r["shadow_rays"]), n(r["rays_rayd"]), n(r["rays_povray"]),
                   "yes" if r["rays_rayd"] == r["rays_povray"] else "**no**", images(r["images"])])
    out += ["", table(["scene", "rayd camera rays", "rayd shadow rays", "rayd rays per frame",
                       "POV-Ray rays per frame", "same work", "images, rayd vs POV-Ray"], rr)]
    return "\n".join(out)


def t_large(sec):
    rows = []
    for r in sec["rows"]:
        b = r["best"]
        rows.append([r["scene"], r["threads"], f(b["rayd_wall_ms"]), f(b["rayd_load_ms"]), f(b["rayd_prepare_ms"]),
                     f(b["rayd_render_ms"]), f(mrays(r["rays_rayd"], b["rayd_render_ms"]), "%.2f"),
                     f(b["povray_wall_ms"]), f(b["povray_parse_ms"]), f(b["povray_bound_ms"]), f(b["povray_trace_ms"]),
                     f(mrays(r["rays_povray"], b["povray_trace_ms"]), "%.2f"),
                     ratio(b["rayd_wall_ms"], b["povray_wall_ms"]), ratio(b["rayd_render_ms"], b["povray_trace_ms"])])
    w, h = sec["settings"]["size"]
    what = "; ".join("**%s**: %s" % (k, v["what"]) for k, v in sec["scenes"].items())
    out = ["%dx%d. %s." % (w, h, what), "",
           table(["scene", "threads", "rayd wall ms", "load ms", "prep ms", "render ms", "rayd Mrays/s",
                  "POV-Ray wall ms", "parse ms", "bound ms", "trace ms", "POV-Ray Mrays/s", "ratio wall",
                  "ratio render"], rows)]
    sp = speedups(sec["rows"], ("rayd_render_ms", "povray_trace_ms"))
    if sp:
        out += ["", table(["speed-up", "rayd render", "POV-Ray trace"], sp)]
    rr = [[r["scene"], n(r["camera_rays"]), n(r["shadow_rays"]), n(r["rays_rayd"]), n(r["rays_povray"]),
           "yes" if r["rays_rayd"] == r["rays_povray"] else "**no**", images(r["images"])]
          for r in sec["rows"] if r["images"] is not None]
    out += ["", table(["scene", "rayd camera rays", "rayd shadow rays", "rayd rays per frame",
                       "POV-Ray rays per frame", "same work", "images, rayd vs POV-Ray"], rr)]
    return "\n".join(out)


def t_cfg2pov(sec):
    rows = [[c["scene"], "%dx%d" % tuple(c["size"]),
             images(c["hand_vs_cfg2pov"]) if c["hand_vs_cfg2pov"] else "(no hand-written file)",
             images(c["rayd_vs_cfg2pov"])] for c in sec["cfg2pov_check"]]
    return table(["scene", "size", "POV-Ray: bench/NAME.pov vs cfg2pov's file", "rayd vs POV-Ray on cfg2pov's file"],
                 rows)


def mib(kb, runs):
    """A peak RSS; None means at most the floor measure.run could see."""
    if kb is not None:
        return "%.1f MiB" % (kb / 1024)
    floor = max((x.get("rss_floor_kb") or 0) for x in runs)
    return "at most %.1f MiB (the floor of the measurement)" % (floor / 1024)


def t_bvh(sec):
    rows = [r for r in sec["rows"] if r["scene"] == "knot1m"]
    if not rows:
        return "(no knot1m in this run)"
    r = rows[0]
    b = r["best"]
    tri = sec["scenes"]["knot1m"]["triangles"]
    return table(["knot1m (%s triangles + 1 plane), rayd --threads %d" % (n(tri), r["threads"]), "value"], [
        ["bvh_build_ms (best)", f(b["rayd_bvh_build_ms"])],
        ["prepare_ms (best)", f(b["rayd_prepare_ms"])],
        ["bvh_nodes", n(r["bvh_nodes"])],
        ["primitives", n(r["primitives"])],
        ["world_bytes", "%s (%.1f MiB)" % (n(r["world_bytes"]), r["world_bytes"] / 2 ** 20)],
        ["bytes per primitive", f(r["world_bytes"] / r["primitives"])],
        ["peak RSS, rayd (largest of the runs)", mib(b["rayd_peak_rss_kb"], r["rayd"])],
        ["peak RSS, POV-Ray (largest of the runs)", mib(b["povray_peak_rss_kb"], r["povray"])],
    ])


def t_base(sec):
    if "skipped" in sec:
        return "Skipped: %s" % sec["skipped"]
    b, s = sec["best"], sec["settings"]
    w, h = s["size"]
    return "\n".join([
        "scenes/diffuse.cfg, %dx%d, --threads 1; render = time_ms, wall = the whole process." % (w, h), "",
        table(["rayd", "render ms", "wall ms"], [
            ["at %s (foundation)" % s["base_short"], f(b["base_render_ms"]), f(b["base_wall_ms"])],
            ["this one", f(b["current_render_ms"]), f(b["current_wall_ms"])],
            ["ratio this / foundation", ratio(b["current_render_ms"], b["base_render_ms"]),
             ratio(b["current_wall_ms"], b["base_wall_ms"])]]),
        "", "Images, foundation vs this rayd: %s." % images(sec["images"])])


def t_http(sec):
    s = sec["settings"]
    sizes = "; ".join("%dx%d: a %s-byte PNG, rendered in %s ms by rayd serve" % (
        x["size"][0], x["size"][1], n(x["png_bytes"]), f(x["render_ms"], "%.2f")) for x in sec["sizes"])
    def lat(w, k):
        # wrk reports 0 for the percentiles of a run in which nothing was answered.
        return f(w[k], "%.2f") if w["requests"] else "none answered"

    rows = []
    for r in sec["rows"]:
        a, b = r["rayd"], r["bare"]
        rows.append(["%dx%d" % tuple(r["size"]), r["connections"], f(a["rps"]), lat(a, "p50_ms"), lat(a, "p99_ms"),
                     a["failed"], f(b["rps"]), lat(b, "p50_ms"), lat(b, "p99_ms"), b["failed"],
                     ratio(a["rps"], b["rps"], "%.3g")])
    return "\n".join([
        "wrk %d s per run; rayd serve with %d render threads, --queue %d; bare_mhd with %d threads. %s." % (
            s["seconds"], s["render_threads"], s["queue"], s["bare_threads"], sizes), "",
        table(["size", "connections", "rayd req/s", "rayd p50 ms", "rayd p99 ms", "rayd failed", "bare req/s",
               "bare p50 ms", "bare p99 ms", "bare failed", "rayd/bare req/s"], rows),
        "", "rayd serve exited %s on SIGTERM." % sec.get("rayd_exit")])


def t_overload(sec):
    s, m, lat = sec["settings"], sec["memory"], sec["latency_ms"]
    codes = ", ".join("%s: %s" % (k, n(v)) for k, v in sorted(sec["codes"].items()))
    only = set(sec["codes"]) <= {"200", "503"}
    rd = sec["rayd_responses"]
    mem = [["fresh (just started)", n(m["fresh"]["rss_kb"]), m["fresh"]["fds"]],
           ["before the load (after warm-up and capacity)", n(m["before"]["rss_kb"]), m["before"]["fds"]],
           ["peak during the load", n(m["peak"]["rss_kb"]), m["peak"]["fds"]]]
    mem += [["%d s after the load" % a["seconds"], n(a["rss_kb"]), a["fds"]] for a in m["after"]]
    return "\n".join([
        "Capacity %s req/s (wrk -c3, closed loop); offered %s req/s = 3x for %d s (hey -q %.4f -c %d); answered %s "
        "(%s req/s sent)." % (f(sec["capacity"]["rps"]), f(sec["offered_rps"]), s["seconds"], sec["hey_q"],
                              s["workers"], n(sec["answered"]), f(sec["sent_rps"])), "",
        "Status codes (hey): %s — %s. rayd's /metrics over the load: 2xx %s, 5xx %s, other %s." % (
            codes, "only 200 and 503" if only else "**other codes too**", n(rd["2xx"]), n(rd["5xx"]),
            n(rd["1xx"] + rd["3xx"] + rd["4xx"])), "",
        table(["latency", "p50 ms", "p99 ms", "answers"],
              [[k, f(v["p50"]), f(v["p99"]), n(v["n"])] for k, v in
               (("200 (accepted)", lat["200"]), ("503 (refused)", lat["503"]), ("all", lat["all"]))]),
        "", table(["rayd's memory and open files", "VmRSS kB", "fds"], mem), "",
        ("Back to the baseline %d s after the load" % sec["back_after_s"] if sec["back_after_s"] is not None
         else "**Not back to the baseline 5 s after the load**")
        + " (same open files, VmRSS within 10% or 2 MiB of before)."])


def t_mixed(sec):
    s, u, big = sec["settings"], sec["summary"], sec["big"]
    return "\n".join([
        table(["%dx%d sync render, ms (%d in a row)" % (s["small_size"][0], s["small_size"][1], s["small"]),
               "p50", "p99", "first"],
              [["alone", f(u["alone_p50"]), f(u["alone_p99"]), ""],
               ["behind the large job", f(u["behind_p50"]), f(u["behind_p99"]), f(u["behind_first"])]]), "",
        "Large job (area_light.cfg %dx%d, %d spp, async): %s, elapsed_ms %s, queued_ms %s, seen ended %s ms after it "
        "was posted; small renders sent while it was queued or running: %d of %d%s." % (
            s["big_size"][0], s["big_size"][1], s["big_samples"], big["status"], f(big["elapsed_ms"], "%.0f"),
            f(big["queued_ms"], "%.1f"), f(big["seen_ended_ms"], "%.0f"), u["overlapping"], s["small"],
            "" if not u["not_200"] else "; **%d did not answer 200**" % u["not_200"])])


def t_converge(sec):
    s = sec["settings"]
    out = ["%dx%d, 1 to %d samples per pixel, reference %d samples; true = RMSE against the reference, its own "
           "error taken out; 1 = 255 levels." % (s["size"][0], s["size"][1], s["max_samples"],
                                                   s["reference_samples"])]
    for c in sec["scenes"]:
        out += ["", "**%s** (plot: `%s`)" % (c["scene"], c["svg"]), "",
                table(["samples", "ms", "estimate", "true", "estimate/true"],
                      [["%g" % r["samples"], f(r["ms"]), f(r["estimate"], "%.6f"), f(r["true"], "%.6f"),
                        f(r["ratio"], "%.2f")] for r in c["rows"]]),
                "", "Log-log slope against samples: true %s, estimate %s." % (
                    f(c["slope_true"], "%.2f"), f(c["slope_estimate"], "%.2f"))]
    return "\n".join(out)


def t_equal_adaptive(sec):
    s = sec["settings"]
    rows = []
    for c in sec["scenes"]:
        for r in c["adaptive_vs_uniform"]:
            rows.append([c["scene"], r["budget_ms"], r["mode"], f(r["stats"]["time_ms"], "%.0f"),
                         f(r["stats"]["mean_samples"], "%.2f"), r["stats"]["passes"],
                         f(r["vs_reference"]["rmse"], "%.5f")])
    refs = "; ".join("%s %s ms, its own error estimate %s" % (
        c["scene"], f(c["references"]["rayd"]["time_ms"], "%.0f"), f(c["references"]["rayd"]["error_estimate"], "%.5f"))
        for c in sec["scenes"])
    return "\n".join([
        "%dx%d, %d thread(s), `--samples 65536 --time-budget-ms B`, with and without `--adaptive`; RMSE against "
        "rayd's own %d-sample reference of another seed (%s)." % (s["size"][0], s["size"][1], s["threads"],
                                                                   s["reference_samples"], refs), "",
        table(["scene", "budget ms", "sampling", "render ms", "spp", "passes", "RMSE"], rows)])


def t_equal_povray(sec):
    s = sec["settings"]
    refs, rows = [], []
    for c in sec["scenes"]:
        rf = c["references"]
        refs.append([c["scene"], "%s spp, %s ms" % (rf["rayd"]["samples"], f(rf["rayd"]["time_ms"], "%.0f")),
                     "`%s`, trace %s ms, %s camera rays per pixel" % (
                         " ".join((rf["povray"]["cfg2pov"] if c["scene"] == "area_light" else [])
                                  + rf["povray"]["antialiasing"]), f(rf["povray"]["trace_ms"], "%.0f"),
                         f(rf["povray"]["camera_rays_per_pixel"], "%.1f")),
                     "%s (rmse %s)" % (images(rf["rayd_vs_povray"]), f(rf["rayd_vs_povray"]["rmse"], "%.5f"))])
        pov = {r["quality"]: r["vs_reference"]["rmse"] for r in c["against_povray"] if r["renderer"] == "povray"}
        for r in c["against_povray"]:
            if r["renderer"] == "povray":
                setting = " ".join(r["settings"]["cfg2pov"] + r["settings"]["antialiasing"])
            elif r["quality"] == "fixed":
                setting = r["mode"]
            else:
                setting = "--time-budget-ms %d%s" % (r["budget_ms"], " --adaptive" if r["mode"] == "adaptive" else "")
            e = r["vs_reference"]["rmse"]
            rel = ratio(e, pov.get(r["quality"])) if r["renderer"] == "rayd" and r["quality"] in pov else ""
            rows.append([c["scene"], "POV-Ray" if r["renderer"] == "povray" else "rayd", r["quality"], "`%s`" % setting,
                         f(r["wall_ms"], "%.0f"), f(r["render_ms"], "%.0f"), f(r["spp"], "%.2f"),
                         f(r["rays_per_pixel"], "%.1f"), f(e, "%.5f"), rel])
    return "\n".join([
        "%dx%d, %d thread(s) for the timed renders, every core for the references." % (
            s["size"][0], s["size"][1], s["threads"]), "",
        table(["scene", "rayd reference", "POV-Ray reference", "rayd's vs POV-Ray's reference"], refs), "",
        table(["scene", "renderer", "quality", "settings", "wall ms", "render ms", "spp", "rays/px", "RMSE",
               "/POV-Ray"], rows)])


def embree_mrays(r, mode):
    m = r["modes"].get(mode)
    return None if not m or not m["best_seconds"] else m["rays"] / m["best_seconds"] / 1e6


def embree_header(sec):
    r = sec["rows"][0]
    w, h = sec["settings"]["size"]
    return ("%dx%d, `rayd render --samples 1 --threads N`; Embree %s (`bench/embree_trace`: `RTC_BUILD_QUALITY_%s`, "
            "built on %d thread, %s-pixel packets, native 16-wide packets: %s). Mrays/s = (camera + shadow rays) / "
            "trace time: rayd's render time without the BVH build (time_ms - prepare_ms), Embree's time to trace "
            "the frame without its build. **rayd also shades every hit (materials, lights, the pixel's colour) while "
            "Embree only traces**, so the ratios understate rayd's tracer; rayd/x below 1 means rayd is slower."
            % (w, h, r["embree_version"], r["quality"].upper(), r["build_threads"], r["tile"],
               "yes" if r["native_ray16"] else "no"))


def same_rays(rayd, other):
    if rayd == other:
        return "yes"
    return "**no** (%+d)" % (other - rayd)


def floor_size(sec):
    fl = {v.get("floor") for v in sec["scenes"].values()}
    return "(%s)" % ", ".join(sorted(x for x in fl if x)) if fl else ""


def t_embree(sec):
    rows = []
    for r in sec["rows"]:
        b = r["best"]
        rm = mrays(r["rays_rayd"], b["rayd_render_ms"])
        es, ep = embree_mrays(r, "single"), embree_mrays(r, "packet")
        rows.append([r["scene"], r["threads"], f(rm, "%.2f"), f(es, "%.2f"), f(ep, "%.2f"), ratio(rm, es),
                     ratio(rm, ep), f(b["rayd_bvh_build_ms"]), f(b["embree_build_ms"])])
    what = "; ".join("**%s**: %s" % (k, v["what"]) for k, v in sec["scenes"].items())
    out = [embree_header(sec), "",
           "Scenes, each on a floor of two triangles %s: %s. Below 9 spheres and triangles (three) rayd builds no "
           "BVH and tests each one." % (floor_size(sec), what), "",
        table(["scene", "threads", "rayd Mrays/s", "Embree rtcIntersect1 Mrays/s", "Embree 16-wide Mrays/s",
               "rayd/1-ray", "rayd/packets", "rayd BVH build ms", "Embree build ms"], rows)]
    sp = speedups(sec["rows"], ("rayd_render_ms", "embree_single_s", "embree_packet_s"))
    if sp:
        out += ["", table(["speed-up", "rayd", "Embree 1-ray", "Embree 16-wide"], sp)]
    return "\n".join(out)


def t_embree_packets(sec):
    rows = []
    for r in sec["rows"]:
        b = r["best"]
        if "rayd_packets_render_ms" not in b:
            continue
        rm, pm = mrays(r["rays_rayd"], b["rayd_render_ms"]), mrays(r["rays_rayd"], b["rayd_packets_render_ms"])
        rows.append([r["scene"], r["threads"], f(rm, "%.2f"), f(pm, "%.2f"), ratio(pm, rm),
                     ratio(pm, embree_mrays(r, "packet"))])
    if not rows:
        return "(this run measured no `--packets all` renders)"
    return "\n".join([
        "`rayd render --packets all` (4x4 pixel blocks: camera rays and shadow rays towards each point or "
        "directional light walked as packets; the same image and ray counts) against rayd ray by ray, on the "
        "runs of the table above.", "",
        table(["scene", "threads", "rayd ray by ray Mrays/s", "rayd --packets all Mrays/s", "packets / ray by ray",
               "packets / Embree 16-wide"], rows)])


def t_embree_rays(sec):
    rows = []
    for r in sec["rows"]:
        s, p = r["modes"]["single"], r["modes"]["packet"]
        rows.append([r["scene"], r["threads"], n(r["primitives"]), n(r["camera_rays"]), n(r["shadow_rays"]),
                     n(s["camera_rays"]), n(s["shadow_rays"]), same_rays(r["rays_rayd"], s["rays"]),
                     n(s["hits"]), n(s["occluded"]), "yes" if r["modes_agree"] else "**no**"])
    return table(["scene", "threads", "primitives", "rayd camera rays", "rayd shadow rays", "Embree camera rays",
                  "Embree shadow rays", "same rays", "Embree hits", "Embree occluded",
                  "1-ray = 16-wide (hits, occluded, checksum)"], rows)


def t_primitives(sec):
    rows, cost = [], {}
    for r in sec["rows"]:
        b = r["best"]
        rm = mrays(r["rays_rayd"], b["rayd_render_ms"])
        es = embree_mrays(r, "single")
        cost[r["triangles"]] = (1e3 / rm if rm else None, 1e3 / es if es else None)
        rows.append([n(r["triangles"]), n(r["primitives"]), n(r["rays_rayd"]), same_rays(r["rays_rayd"],
                                                                                          r["modes"]["single"]["rays"]),
                     f(rm, "%.2f"), f(cost[r["triangles"]][0]), f(es, "%.2f"), f(cost[r["triangles"]][1]),
                     ratio(rm, es), f(b["rayd_bvh_build_ms"]), f(b["embree_build_ms"])])
    w, h = sec["settings"]["size"]
    out = ["%dx%d, 1 thread; scenes/gen.py bumpy SEGS RINGS: the same bumpy Lambert sphere in 2*SEGS*(RINGS-1) "
           "flat triangles, on a floor of two triangles, 2 point lights; `rayd render --samples 1` against "
           "bench/embree_trace's rtcIntersect1/rtcOccluded1 on the same rays. ns/ray = trace time / (camera + "
           "shadow rays); rayd's also shades." % (w, h), "",
           table(["triangles", "primitives", "rays", "same rays in Embree", "rayd Mrays/s", "rayd ns/ray",
                  "Embree 1-ray Mrays/s", "Embree ns/ray", "rayd/Embree", "rayd BVH build ms", "Embree build ms"],
                 rows)]
    if len(cost) >= 2:
        lo, hi = min(cost), max(cost)
        cr = ratio(cost[hi][0], cost[lo][0])
        target = sec["settings"].get("target", 3.0)
        met = cost[hi][0] is not None and cost[lo][0] and cost[hi][0] / cost[lo][0] <= target
        out += ["", "Cost of a ray at %s triangles over %s: rayd %sx (target: at most %gx, %s), Embree %sx." % (
            n(hi), n(lo), cr, target, "met" if met else "**not met**", ratio(cost[hi][1], cost[lo][1]))]
    return "\n".join(out)


# marker -> (section, table function)
MARKERS = {
    "scenes": ("scenes", t_scenes), "large": ("large", t_large), "cfg2pov": ("large", t_cfg2pov),
    "bvh": ("large", t_bvh), "embree": ("embree", t_embree), "embree-rays": ("embree", t_embree_rays),
    "embree-packets": ("embree", t_embree_packets),
    "primitives": ("primitives", t_primitives), "base": ("base", t_base), "http": ("http", t_http), "overload": ("overload", t_overload),
    "mixed": ("mixed", t_mixed), "converge": ("converge", t_converge),
    "equal-adaptive": ("equal", t_equal_adaptive), "equal-povray": ("equal", t_equal_povray),
}


def section_text(name, sec, results=None):
    """Every table of one section, with its provenance (what the driver prints)."""
    parts = [fn(sec) for m, (s, fn) in MARKERS.items() if s == name]
    return "\n\n".join(parts + [provenance(sec)]) + "\n"


def rewrite(text, sections, allow_quick, log):
    """text with every generated block whose section is in sections redone."""
    pat = re.compile(r"(<!-- generated:([a-z0-9-]+) -->\n)(.*?)(<!-- end -->)", re.S)

    def one(m):
        marker = m.group(2)
        if marker not in MARKERS:
            log("unknown marker generated:%s, left as it is" % marker)
            return m.group(0)
        name, fn = MARKERS[marker]
        sec = sections.get(name)
        if sec is None:
            return m.group(0)
        if "error" in sec:
            log("%s: the section failed in that run, left as it is" % marker)
            return m.group(0)
        if sec.get("quick") and not allow_quick:
            log("%s: from a --quick run, left as it is (--allow-quick writes it)" % marker)
            return m.group(0)
        log("%s: from the run of %s" % (marker, sec.get("started")))
        return m.group(1) + fn(sec) + "\n\n" + provenance(sec) + "\n" + m.group(4)

    return pat.sub(one, text)


def load(paths):
    sections = {}
    for p in paths:
        with open(p) as fh:
            sections.update(json.load(fh)["sections"])
    return sections


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m rayd_bench.report", description=__doc__.split("\n\n")[0])
    ap.add_argument("--results", nargs="+", default=[os.path.join(ROOT, "build", "bench", "results.json")])
    ap.add_argument("--readme", default=os.path.join(ROOT, "bench", "README.md"))
    ap.add_argument("--print", action="store_true", help="print the tables instead of rewriting the README")
    ap.add_argument("--allow-quick", action="store_true", help="also write sections of --quick runs")
    a = ap.parse_args(argv)
    # Sections that keep their tables beside their code add them to MARKERS
    # when imported (the store section does).
    from . import sections as _registers  # noqa: F401
    # Run as `python3 -m rayd_bench.report` this module is __main__, and the
    # sections registered their tables in rayd_bench.report: take them.
    from . import report as _package_report
    for k, v in _package_report.MARKERS.items():
        MARKERS.setdefault(k, v)
    try:
        sections = load(a.results)
    except (OSError, ValueError, KeyError) as e:
        print("report: cannot read the results: %s" % e, file=sys.stderr)
        return 2
    if a.print:
        for name, sec in sections.items():
            print("## %s\n" % name)
            print(sec["error"] if "error" in sec else section_text(name, sec))
        return 0
    try:
        with open(a.readme) as fh:
            text = fh.read()
    except OSError as e:
        print("report: %s" % e, file=sys.stderr)
        return 2
    new = rewrite(text, sections, a.allow_quick, lambda msg: print("report: " + msg, file=sys.stderr))
    if new != text:
        tmp = a.readme + ".tmp"
        with open(tmp, "w") as fh:
            fh.write(new)
        os.replace(tmp, a.readme)
    return 0


if __name__ == "__main__":
    sys.exit(main())
