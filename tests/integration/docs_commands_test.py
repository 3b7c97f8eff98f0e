#!/usr/bin/env python3
"""Every command line of README.md and docs/*.md that starts with
`build/rayd` or `curl` is run, and a non-zero exit fails the test.

Lines are run in the order a file gives them, with sh, in a temporary
folder of that file's own where scenes/, deploy/, docs/ and tests/ are the
repository's (so a line may use what an earlier one wrote). `build/rayd`
is $RAYD. The curl lines talk to a daemon this test starts on 127.0.0.1
at a port it picks (stopped by its pid): `127.0.0.1:8080` in a line
becomes that address. A line the test cannot run carries, in its own
shell comment, `not run by the docs test: WHY`; the test prints each such
line with its reason, and a marker without a reason is a failure.

Usage: RAYD=build/rayd /usr/bin/python3 tests/integration/docs_commands_test.py
(from the repository root).
"""
import glob
import os
import re
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from rayd_http import Daemon  # noqa: E402

ROOT = os.getcwd()
RAYD = os.path.abspath(os.environ.get("RAYD", "build/rayd"))
MARK = "not run by the docs test:"
START = re.compile(r"^\s*(build/rayd|curl)(\s|$)")
TIMEOUT = 600


def command_lines(path):
    """(line number, command) of each line that starts a command, with its
    backslash continuations joined."""
    out, lines, i = [], open(path, encoding="utf-8").read().split("\n"), 0
    while i < len(lines):
        if START.match(lines[i]):
            n, text = i + 1, lines[i].strip()
            while text.endswith("\\") and i + 1 < len(lines):
                i += 1
                text = text[:-1] + " " + lines[i].strip()
            out.append((n, text))
        i += 1
    return out


def main():
    files = ["README.md"] + sorted(glob.glob("docs/*.md"))
    tmp = tempfile.mkdtemp(prefix="rayd-docs-test-")
    try:
        daemon = Daemon(tmp, ["--scenes", os.path.join(ROOT, "scenes"), "--threads", "2"])
    except RuntimeError as e:
        sys.exit("docs commands: %s" % e)
    port = daemon.port
    passed, failed, skipped = 0, 0, []
    try:
        for path in files:
            work = os.path.join(tmp, "run-" + os.path.basename(path))
            os.mkdir(work)
            for d in ("scenes", "deploy", "docs", "tests"):
                os.symlink(os.path.join(ROOT, d), os.path.join(work, d))
            for n, text in command_lines(path):
                where = "%s:%d" % (path, n)
                if MARK in text:
                    why = text.split(MARK, 1)[1].strip()
                    if not why:
                        failed += 1
                        print("FAIL: %s is marked as not run but says not why: %s" % (where, text))
                    else:
                        skipped.append((where, why))
                    continue
                cmd = re.sub(r"^build/rayd(?=\s|$)", RAYD.replace("\\", "\\\\"), text)
                cmd = cmd.replace("127.0.0.1:8080", "127.0.0.1:%d" % port)
                try:
                    r = subprocess.run(["sh", "-c", cmd], cwd=work, stdin=subprocess.DEVNULL,
                                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=TIMEOUT)
                    rc, err = r.returncode, r.stderr.decode("utf-8", "replace")
                except subprocess.TimeoutExpired:
                    rc, err = "timeout", "over %d s" % TIMEOUT
                if rc == 0:
                    passed += 1
                else:
                    failed += 1
                    print("FAIL: %s exit %s: %s\n    %s" % (where, rc, text, err.strip()[-400:].replace("\n", "\n    ")))
    finally:
        daemon.proc.terminate()
        daemon.proc.wait()
    for where, why in skipped:
        print("not run: %s: %s" % (where, why))
    print("docs commands: %d passed, %d failed, %d not run (each named above)" % (passed, failed, len(skipped)))
    if failed == 0:
        shutil.rmtree(tmp)
    else:
        print("their folders: " + tmp)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
