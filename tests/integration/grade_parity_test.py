#!/usr/bin/env python3
"""`rayd grade` and POST /v1/grade answer the same input alike.

For one input of every class (a pass, a fail, and each way a grade can go
wrong) this runs the command and posts the same form to a daemon started
with the same assignments, scenes and limits, then checks:
  - the exit status and the HTTP status and error code are the pair the
    error table gives (docs/grading.md);
  - the error message is the same text, up to the scene's name (the file
    path on the command line, <upload> over HTTP);
  - for a graded image, the verdict JSON is the same, but for the fields only
    the daemon has (id, the image addresses, the record: a grade of the
    command is no record).

Usage: RAYD=build/rayd /usr/bin/python3 tests/integration/grade_parity_test.py
(from the repository root). The daemon listens on 127.0.0.1 on a port it
picks, and is stopped by its pid.
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from rayd_http import RAYD, form, png  # noqa: E402

LIMITS = ["--limit-samples", "16"]
passed = failed = 0


def check(cond, what):
    global passed, failed
    if cond:
        passed += 1
    else:
        failed += 1
        print("FAIL:", what, file=sys.stderr)


def post_grade(port, fields):
    body, ctype = form(fields)
    req = urllib.request.Request("http://127.0.0.1:%d/v1/grade" % port, data=body,
                                 headers={"Content-Type": ctype})
    try:
        with urllib.request.urlopen(req, timeout=120) as r:
            return r.status, json.loads(r.read())
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read())


def cli_grade(args):
    p = subprocess.run([RAYD, "grade", "--threads", "2"] + LIMITS + args, capture_output=True, timeout=300)
    return p.returncode, p.stdout.decode(), p.stderr.decode()


def start_daemon(tmp, assignments, scenes):
    port_file = os.path.join(tmp, "port")
    log = open(os.path.join(tmp, "daemon.log"), "wb")
    proc = subprocess.Popen([RAYD, "serve", "--listen", "127.0.0.1:0", "--port-file", port_file, "--threads", "2",
                             "--assignments", assignments, "--scenes", scenes,
                             "--data-dir", os.path.join(tmp, "var")] + LIMITS,
                            stdout=log, stderr=log)
    for _ in range(500):
        if os.path.exists(port_file) and open(port_file).read().strip():
            return proc, int(open(port_file).read())
        if proc.poll() is not None:
            break
        time.sleep(0.02)
    proc.kill()
    sys.exit("grade_parity: the daemon did not start; see %s/daemon.log" % tmp)


def main():
    tmp = tempfile.mkdtemp(prefix="rayd-grade-parity-")
    assignments = os.path.join(tmp, "assignments")
    scenes = os.path.join(tmp, "scenes")
    os.makedirs(scenes)
    shutil.copytree("scenes/assignments", assignments)
    with open("scenes/assignments/phong.cfg") as f:
        phong_text = f.read()
    # Broken assignments: a .grade file with a bad value, a scene that does not parse.
    shutil.copy("scenes/assignments/phong.cfg", os.path.join(assignments, "badgrade.cfg"))
    with open(os.path.join(assignments, "badgrade.grade"), "w") as f:
        f.write("title = broken\nfail = three\n")
    with open(os.path.join(assignments, "badscene.cfg"), "w") as f:
        f.write("[render]\nwidth = wide\n")

    def scene_file(name, text):
        path = os.path.join(scenes, name)
        with open(path, "w") as f:
            f.write(text)
        return path

    ref_png = os.path.join(tmp, "phong.png")
    subprocess.run([RAYD, "render", "scenes/assignments/phong.cfg", "-o", ref_png], check=True,
                   capture_output=True)
    good = open(ref_png, "rb").read()
    other = os.path.join(tmp, "diffuse.png")
    subprocess.run([RAYD, "render", "scenes/assignments/diffuse.cfg", "-o", other, "--width", "320",
                    "--height", "240"], check=True, capture_output=True)
    wrong = open(other, "rb").read()
    small = png(4, 3, lambda x, y: (x * 60, y * 80, 100))

    # (name, CLI scene source, form fields, exit, HTTP status, error code or None when graded)
    cases = []
    cases.append(("pass", ["--assignment", "phong"], {"assignment": b"phong", "image": good}, 0, 200, None))
    cases.append(("fail", ["--assignment", "phong"], {"assignment": b"phong", "image": wrong}, 4, 200, None))
    cases.append(("unknown assignment", ["--assignment", "nosuch"], {"assignment": b"nosuch", "image": good},
                  1, 404, "not_found"))
    cases.append(("bad .grade file", ["--assignment", "badgrade"], {"assignment": b"badgrade", "image": good},
                  2, 422, "bad_assignment"))
    cases.append(("assignment scene does not parse", ["--assignment", "badscene"],
                  {"assignment": b"badscene", "image": good}, 2, 422, "bad_assignment"))
    bad = "[render]\nwidth = 64O\n"
    cases.append(("scene syntax", ["--scene", scene_file("syntax.cfg", bad)],
                  {"scene": bad.encode(), "image": good}, 2, 400, "parse_error"))
    invalid = phong_text.replace("material = ", "material = nosuch_", 1)
    cases.append(("scene invalid", ["--scene", scene_file("invalid.cfg", invalid)],
                  {"scene": invalid.encode(), "image": good}, 2, 422, "invalid_scene"))
    over = phong_text.replace("[render]\n", "[render]\nsamples = 64\n", 1)
    cases.append(("scene over a limit", ["--scene", scene_file("over.cfg", over)],
                  {"scene": over.encode(), "image": good}, 2, 413, "too_large"))
    mesh = ("[render]\nwidth = 320\nheight = 240\n[material m]\ntype = diffuse\nkd = 0.5 0.5 0.5\n"
            "[mesh]\nfile = nosuch.obj\nmaterial = m\n")
    cases.append(("scene's mesh missing", ["--scene", scene_file("mesh.cfg", mesh)],
                  {"scene": mesh.encode(), "image": good}, 3, 422, "missing_file"))
    cases.append(("not a PNG", ["--assignment", "phong"], {"assignment": b"phong", "image": b"GIF89a...."},
                  2, 415, "unsupported_media_type"))
    cases.append(("damaged PNG", ["--assignment", "phong"], {"assignment": b"phong", "image": good[:200]},
                  2, 422, "bad_image"))
    cases.append(("wrong size", ["--assignment", "phong"], {"assignment": b"phong", "image": small},
                  2, 422, "size_mismatch"))

    proc, port = start_daemon(tmp, assignments, scenes)
    try:
        for name, cli_args, fields, want_exit, want_status, want_code in cases:
            image = os.path.join(tmp, "image.png")
            with open(image, "wb") as f:
                f.write(fields["image"])
            if "--assignment" in cli_args:
                cli_args = cli_args + ["--assignments", assignments]
            rc, out, err = cli_grade(cli_args + ["--image", image])
            status, answer = post_grade(port, fields)
            check(rc == want_exit, "%s: exit %d, expected %d (%s)" % (name, rc, want_exit, err.strip()))
            check(status == want_status, "%s: HTTP %d, expected %d (%s)" % (name, status, want_status, answer))
            if want_code is None:
                verdict = json.loads(out) if rc in (0, 4) else {}
                for key in ("id", "diff_url", "reference_url", "image_url", "reference_cached", "record"):
                    answer.pop(key, None)
                    verdict.pop(key, None)
                check(verdict == answer, "%s: verdicts differ:\n  cli  %s\n  http %s" % (name, verdict, answer))
                continue
            got = answer.get("error", {})
            check(got.get("code") == want_code, "%s: error code %s, expected %s" % (name, got.get("code"), want_code))
            message = got.get("message", "")
            # The command line adds a line naming the folder it searched,
            # which the daemon never shows.
            cli_lines = err.strip().splitlines()
            cli_message = cli_lines[0] if cli_lines else ""
            if want_code == "not_found" and "--assignment" in cli_args:
                check(len(cli_lines) == 2 and cli_lines[1].startswith("rayd grade: searched ") and
                      cli_args[cli_args.index("--assignments") + 1] in cli_lines[1],
                      "%s: rayd grade names the folder it searched: %r" % (name, err))
            if cli_message.startswith("rayd grade: "):
                cli_message = cli_message[len("rayd grade: "):]
            if "--scene" in cli_args:
                cli_message = cli_message.replace(cli_args[cli_args.index("--scene") + 1], "<upload>")
            check(cli_message == message, "%s: messages differ:\n  cli  %s\n  http %s" % (name, cli_message, message))
            check(tmp not in message, "%s: the answer shows the server's folder: %s" % (name, message))
        # A broken assignment hides nothing but itself: listed with its
        # error (file names only), the others as always.
        with urllib.request.urlopen("http://127.0.0.1:%d/v1/assignments" % port, timeout=30) as r:
            listed = {a["name"]: a for a in json.loads(r.read())["assignments"]}
        check(set(listed) >= {"badgrade", "badscene", "phong", "diffuse"}, "assignments listed: %s" % sorted(listed))
        bad = listed.get("badgrade", {})
        check(bad.get("error", "").startswith("badgrade.grade:2:8: ") and "thresholds" not in bad,
              "the broken .grade file is listed with its error: %r" % bad)
        check("error" in listed.get("badscene", {}), "the broken scene is listed with its error")
        check("error" not in listed.get("phong", {}) and "thresholds" in listed.get("phong", {}),
              "the working assignments are listed as always")
        check(all(tmp not in json.dumps(a) for a in listed.values()), "no listed error shows the server's folder")
        # The daemon keeps references: the second grade of an assignment does not render.
        status, answer = post_grade(port, {"assignment": b"phong", "image": good})
        check(status == 200 and answer.get("reference_cached") is True,
              "a second grade of phong: reference_cached %s" % answer.get("reference_cached"))
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            rc = proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            rc = -1
        check(rc == 0, "daemon exit status %d after SIGTERM" % rc)
    shutil.rmtree(tmp)
    print("grade parity: %d passed, %d failed" % (passed, failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
