#!/usr/bin/env python3
"""What an operator expects of `rayd serve`: options and their environment
variables, listening addresses, start-up checks, /readyz, the log (text and
JSON, request ids, clients behind trusted proxies), per-client limits,
caching headers, CORS, SIGHUP, a grade's address answering a browser with
the page and everyone else with JSON.

Usage: RAYD=build/rayd /usr/bin/python3 tests/integration/serve_test.py
(from the repository root). Every daemon listens on loopback on a port it
picks and is stopped by its pid.
"""
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from rayd_http import RAYD, Checks, form, render_png  # noqa: E402
from rayd_http import Daemon as _Daemon  # noqa: E402

t = Checks("serve_test")
SCENE = open("scenes/phong.cfg", "rb").read()
SLOW = open("scenes/area_light.cfg", "rb").read()
SLOW_QUERY = "/v1/render?width=320&height=240&samples=4096"


def Daemon(flags=(), **kw):
    """A daemon with its own temporary folder."""
    return _Daemon(tempfile.mkdtemp(prefix="rayd-serve-test-"), flags, **kw)


def run(args, env=None):
    e = dict(os.environ)
    e.update(env or {})
    p = subprocess.run([RAYD] + args, capture_output=True, env=e, timeout=60)
    return p.returncode, p.stdout.decode(), p.stderr.decode()


def ipv6_loopback():
    try:
        s = socket.socket(socket.AF_INET6, socket.SOCK_STREAM)
        s.bind(("::1", 0))
        s.close()
        return True
    except OSError:
        return False


def test_listen_forms():
    forms = [("127.0.0.1:0", "127.0.0.1"), ("localhost:0", "127.0.0.1"), (":0", "127.0.0.1")]
    if ipv6_loopback():
        forms.append(("[::1]:0", "::1"))
    for listen, host in forms:
        with Daemon(listen=listen, host=host) as d:
            status, _, body = d.request("GET", "/healthz")
            t(status == 200, "--listen %s: GET /healthz over %s answers %d" % (listen, host, status))
    # --listen=VALUE is the same as --listen VALUE.
    with Daemon(["--listen=127.0.0.1:0"], listen=None) as d:
        t(d.request("GET", "/healthz")[0] == 200, "--listen=127.0.0.1:0 serves")
    for bad in ["no-such-host.invalid:80", "127.0.0.1", "127.0.0.1:65536", "::1:80", "127.0.0.1:http", "[::1:80"]:
        rc, _, err = run(["serve", "--listen", bad])
        t(rc == 1 and "--listen" in err and bad in err,
                "--listen %s is a usage error naming the flag and value (exit %d, %r)" % (bad, rc, err.strip()))


def test_options_and_environment():
    rc, out, _ = run(["serve", "--help"])
    flags = re.findall(r"^  --([a-z-]+) ", out, re.M)
    t(rc == 0 and len(flags) >= 20, "serve --help lists its flags (%d)" % len(flags))
    for f in flags:
        env = "RAYD_" + f.upper().replace("-", "_")
        t(env in out, "serve --help names %s for --%s" % (env, f))
    with Daemon(env={"RAYD_THREADS": "1"}) as d:
        t("(1 render threads" in d.text(), "RAYD_THREADS=1 sets the render threads: " + d.text()[:200])
    with Daemon(["--threads", "2"], env={"RAYD_THREADS": "1"}) as d:
        t("(2 render threads" in d.text(), "--threads wins over RAYD_THREADS")
    d = Daemon(listen=None, env={"RAYD_LISTEN": "127.0.0.1:0"})
    t(d.request("GET", "/healthz")[0] == 200, "RAYD_LISTEN sets the address")
    d.stop()
    rc, _, err = run(["serve"], env={"RAYD_THREADS": "many"})
    t(rc == 1 and "RAYD_THREADS" in err, "a bad RAYD_THREADS is a usage error naming it: %r" % err)
    rc, _, err = run(["serve"], env={"RAYD_LIMIT_PIXELS": "0"})
    t(rc == 1 and "RAYD_LIMIT_PIXELS" in err, "a limit's environment variable is read: %r" % err)
    rc, _, err = run(["serve", "--no-such-flag", "1"])
    t(rc == 1 and "--no-such-flag" in err, "an unknown flag is a usage error: %r" % err)
    rc, _, err = run(["serve", "--threads"])
    t(rc == 1 and "--threads" in err, "a flag without its value is a usage error: %r" % err)


def test_start_checks():
    tmp = tempfile.mkdtemp()
    missing = os.path.join(tmp, "nothing-here")
    for flag in ["--scenes", "--assignments"]:
        rc, _, err = run(["serve", "--listen", "127.0.0.1:0", flag, missing])
        t(rc == 3 and missing in err and flag in err,
                "%s of a missing folder fails at start naming it (exit %d, %r)" % (flag, rc, err.strip()))
    blocker = os.path.join(tmp, "a-file")
    open(blocker, "w").close()
    bad_cache = os.path.join(blocker, "cache")
    rc, _, err = run(["serve", "--listen", "127.0.0.1:0", "--cache-dir", bad_cache])
    t(rc == 3 and "--cache-dir" in err and blocker in err,
            "a --cache-dir that cannot be created fails at start (exit %d, %r)" % (rc, err.strip()))
    made = os.path.join(tmp, "new", "nested", "cache")
    with Daemon(["--cache-dir", made]) as d:
        t(os.path.isdir(made), "--cache-dir is created when missing")
    shutil.rmtree(tmp)


def slow_render(d, headers=None, results=None):
    """A sync render that takes seconds, on its own thread."""
    def go():
        try:
            results.append(d.request("POST", SLOW_QUERY, body=SLOW, headers=headers or {}, timeout=120)[0])
        except Exception as e:  # the daemon stopping may close it
            results.append(repr(e))
    th = threading.Thread(target=go)
    th.start()
    return th


def wait_running(d, n=1, timeout=10):
    deadline = time.time() + timeout
    while time.time() < deadline:
        _, _, body = d.request("GET", "/metrics")
        m = re.search(rb"^rayd_jobs_running (\d+)", body, re.M)
        if m and int(m.group(1)) >= n:
            return True
        time.sleep(0.05)
    return False


def test_readyz():
    d = Daemon(["--threads", "1", "--drain-ms", "3000"])
    status, headers, body = d.request("GET", "/readyz")
    t(status == 200 and json.loads(body)["status"] == "ready", "/readyz is 200 once started")
    results = []
    th = slow_render(d, results=results)
    t(wait_running(d), "the slow render runs")
    d.send(signal.SIGTERM)
    time.sleep(0.3)
    status, headers, body = d.request("GET", "/readyz")
    t(status == 503 and "draining" in json.loads(body).get("reasons", []),
            "/readyz is 503 draining while it drains (%d %r)" % (status, body))
    status, _, _ = d.request("GET", "/healthz")
    t(status == 200, "/healthz stays 200 while draining (%d)" % status)
    th.join()
    t(d.stop() == 0, "SIGTERM exits 0")


def test_json_log():
    with Daemon(["--log-format", "json"]) as d:
        status, headers, _ = d.request("GET", "/healthz?probe=1", headers={"User-Agent": "checker/1.0"})
        rid = headers.get("x-request-id", "")
        t(re.fullmatch(r"[0-9a-f]{16}", rid) is not None, "an answer carries X-Request-Id: %r" % rid)
        status, headers, _ = d.request("GET", "/no/such", headers={"X-Request-Id": "abc-123.x"})
        t(headers.get("x-request-id") == "abc-123.x", "a caller's plain X-Request-Id is kept")
        status, headers, _ = d.request("GET", "/healthz", headers={"X-Request-Id": "bad id with spaces"})
        t(headers.get("x-request-id") != "bad id with spaces", "a caller's odd X-Request-Id is replaced")
        d.send(signal.SIGHUP)
        time.sleep(0.3)
    lines = [l for l in d.text().splitlines() if l.strip()]
    objs = []
    for l in lines:
        try:
            objs.append(json.loads(l))
        except ValueError:
            t(False, "every log line is JSON: %r" % l)
    t(len(objs) == len(lines) and len(objs) >= 6, "every line of the JSON log parses (%d)" % len(objs))
    t(all({"time", "level", "msg"} <= set(o) for o in objs), "every JSON line has time, level and msg")
    msgs = " | ".join(o["msg"] for o in objs)
    t("listening on" in msgs and "stopped" in msgs and "SIGHUP" in msgs,
            "start-up, SIGHUP and shutdown are logged as JSON: " + msgs[:300])
    start = next((o for o in objs if "listening on" in o["msg"]), {})
    t(bool(start.get("version")) and start.get("port") == d.port, "the start-up line has version and port")
    acc = [o for o in objs if o.get("path") == "/healthz" and o.get("query") == "probe=1"]
    t(len(acc) == 1, "the access line has the query string")
    if acc:
        a = acc[0]
        t(a.get("client") == "127.0.0.1" and a.get("user_agent") == "checker/1.0" and
                a.get("request_id") == rid and a.get("status") == 200,
                "the access line has client, user agent, request id and status: %r" % a)


def test_library_messages_in_json():
    # libmicrohttpd says something when it refuses a connection over the
    # per-address limit; that line must be JSON too.
    with Daemon(["--log-format", "json", "--max-per-ip", "1"]) as d:
        socks = [socket.create_connection(("127.0.0.1", d.port)) for _ in range(4)]
        time.sleep(0.5)
        for c in socks:
            c.close()
    lines = [l for l in d.text().splitlines() if l.strip()]
    lib = [l for l in lines if "libmicrohttpd" in l]
    t(len(lib) >= 1 and all("not the first option" not in l for l in lib),
      "the per-address limit made libmicrohttpd say something (and nothing about its options): %r" % lib[:2])
    t(all(l.startswith("{") and json.loads(l).get("level") == "warning" for l in lib),
            "libmicrohttpd's messages are JSON warnings: %r" % lib[:2])


def test_text_log_and_proxy():
    with Daemon(["--trust-proxy", "127.0.0.1"]) as d:
        d.request("GET", "/healthz", headers={"X-Forwarded-For": "198.51.100.7, 127.0.0.1"})
        d.request("GET", "/healthz", headers={"X-Forwarded-For": "not-an-address, 203.0.113.9"})
    log = d.text()
    t(re.search(r"Z 198\.51\.100\.7 GET /healthz 200 ", log) is not None,
            "behind a trusted proxy the client is the X-Forwarded-For address: " + log[-400:])
    t(re.search(r"Z 203\.0\.113\.9 GET /healthz 200 ", log) is not None,
            "the walk stops at an entry that is not an address")
    with Daemon() as d:
        d.request("GET", "/healthz", headers={"X-Forwarded-For": "198.51.100.7"})
    t(re.search(r"Z 127\.0\.0\.1 GET /healthz 200 ", d.text()) is not None and "198.51.100.7" not in d.text(),
            "without --trust-proxy X-Forwarded-For is ignored")
    rc, _, err = run(["serve", "--listen", "127.0.0.1:0", "--trust-proxy", "10.0.0.1,proxy.example"])
    t(rc != 0 and "proxy.example" in err, "--trust-proxy refuses what is not an address: %r" % err.strip())


def test_per_client_limit():
    d = Daemon(["--trust-proxy", "127.0.0.1", "--max-per-ip", "1", "--threads", "1"])
    results = []
    th = slow_render(d, headers={"X-Forwarded-For": "192.0.2.1"}, results=results)
    t(wait_running(d), "the first client's render runs")
    same, _, _ = d.request("GET", "/healthz", headers={"X-Forwarded-For": "192.0.2.1"})
    other, _, _ = d.request("GET", "/healthz", headers={"X-Forwarded-For": "192.0.2.2"})
    t(same == 429, "--max-per-ip counts the real client behind the proxy: a second request gets %d" % same)
    t(other == 200, "another client behind the same proxy is served (%d)" % other)
    d.stop()
    th.join()


def test_caching_headers():
    with Daemon() as d:
        status, headers, body = d.request("POST", "/v1/jobs?width=64&height=48", body=SCENE)
        job = json.loads(body)["id"]
        for _ in range(200):
            if json.loads(d.request("GET", "/v1/jobs/" + job)[2])["status"] == "done":
                break
            time.sleep(0.05)
        status, headers, png = d.request("GET", "/v1/jobs/%s/image" % job)
        etag = headers.get("etag", "")
        t(status == 200 and etag.startswith('"') and job in etag, "a job image has an ETag: %r" % etag)
        t("immutable" in headers.get("cache-control", ""), "and Cache-Control immutable")
        status, headers, body = d.request("GET", "/v1/jobs/%s/image" % job, headers={"If-None-Match": etag})
        t(status == 304 and body == b"", "If-None-Match of its ETag answers 304 without a body (%d)" % status)
        status, _, again = d.request("GET", "/v1/jobs/%s/image" % job, headers={"If-None-Match": '"other"'})
        t(status == 200 and again == png, "another ETag gets the image again")


def test_cors():
    with Daemon() as d:
        status, headers, _ = d.request("OPTIONS", "/v1/render")
        t(status == 204 and "POST" in headers.get("allow", ""), "OPTIONS answers 204 with Allow")
        t("access-control-allow-origin" not in headers, "no CORS headers without --cors-origin")
        status, headers, _ = d.request("OPTIONS", "/no/such")
        t(status == 404, "OPTIONS of no route is 404 (%d)" % status)
    with Daemon(["--cors-origin", "https://course.example"]) as d:
        status, headers, _ = d.request("OPTIONS", "/v1/jobs", headers={
            "Origin": "https://course.example", "Access-Control-Request-Method": "POST"})
        t(status == 204 and headers.get("access-control-allow-origin") == "https://course.example" and
                "POST" in headers.get("access-control-allow-methods", ""), "a preflight is answered: %r" % headers)
        status, headers, _ = d.request("GET", "/healthz", headers={"Origin": "https://course.example"})
        t(headers.get("access-control-allow-origin") == "https://course.example" and
                "X-Request-Id" in headers.get("access-control-expose-headers", "") and
                headers.get("vary") == "Origin", "answers carry the CORS headers: %r" % headers)


# What Chromium sends when it opens a link, and curl by default.
BROWSER_ACCEPT = ("text/html,application/xhtml+xml,application/xml;q=0.9,image/avif,image/webp,image/apng,*/*;q=0.8,"
                  "application/signed-exchange;v=b3;q=0.7")


def test_verdict_page():
    """GET /v1/grades/{id}: the page to a client that prefers text/html,
    the verdict's JSON to every other, the same status either way, and a
    Vary that names Accept (beside CORS's Origin)."""
    tmp = tempfile.mkdtemp(prefix="rayd-serve-test-")
    image = render_png("scenes/assignments/phong.cfg", os.path.join(tmp, "mine.png"))
    with Daemon(["--cors-origin", "https://course.example"]) as d:
        body, ct = form({"assignment": b"phong", "image": image})
        status, _, data = d.request("POST", "/v1/grade", body=body, headers={"Content-Type": ct})
        gid = json.loads(data)["id"] if status == 200 else "g" + "0" * 32
        t(status == 200, "the grade is answered: %d %r" % (status, data[:200]))
        url = "/v1/grades/" + gid
        json_accepts = [None, "*/*", "application/json", "application/json, text/html;q=0.9",
                        "text/html;q=0.5, application/json", "text/html;q=0", "text/html;q=2", "image/png",
                        "text/html;;;q=,,,", ",;=" * 2000]
        for accept in json_accepts:
            status, headers, data = d.request("GET", url, headers={"Accept": accept} if accept else {})
            try:
                same = json.loads(data).get("id") == gid
            except ValueError:
                same = False
            t(status == 200 and headers.get("content-type") == "application/json" and same,
              "Accept %r gets the verdict's JSON: %d %r" % ((accept or "")[:60], status, headers.get("content-type")))
            t(headers.get("vary") == "Origin, Accept", "Accept %r: Vary %r" % ((accept or "")[:60], headers.get("vary")))
        for accept in [BROWSER_ACCEPT, "text/html", "TEXT/HTML", "text/*", "text/html ;q=0.9, application/json;q=0.8",
                       "text/html, */*;q=0.1"]:
            status, headers, data = d.request("GET", url, headers={"Accept": accept})
            t(status == 200 and headers.get("content-type") == "text/html; charset=utf-8" and
              data.startswith(b"<!doctype html>") and b"showOneGrade" in data,
              "Accept %r gets the page: %d %r" % (accept[:60], status, headers.get("content-type")))
            t(headers.get("vary") == "Origin, Accept", "the page: Vary %r" % headers.get("vary"))
            t(headers.get("referrer-policy") == "no-referrer", "the page sends no Referer: %r" % headers)
        for missing in ["g" + "0" * 32, "gnot-an-id", "x" * 150]:
            status, headers, data = d.request("GET", "/v1/grades/" + missing, headers={"Accept": BROWSER_ACCEPT})
            t(status == 404 and headers.get("content-type", "").startswith("text/html"),
              "a browser's link to no grade (%s) is a 404 page: %d %r" % (missing[:40], status, headers.get("content-type")))
            status, headers, data = d.request("GET", "/v1/grades/" + missing)
            t(status == 404 and json.loads(data)["error"]["code"] == "not_found" and
              headers.get("vary") == "Origin, Accept", "and curl's is the 404's JSON: %d %r" % (status, data[:120]))
        status, headers, data = d.request("GET", url + "/diff.png", headers={"Accept": BROWSER_ACCEPT})
        t(status == 200 and data.startswith(b"\x89PNG") and headers.get("vary") == "Origin",
          "a grade's images do not depend on Accept: %d %r" % (status, headers.get("vary")))
    with Daemon() as d:
        status, headers, _ = d.request("GET", "/v1/grades/g" + "0" * 32)
        t(status == 404 and headers.get("vary") == "Accept", "without CORS, Vary is Accept alone: %r" % headers)
        status, headers, _ = d.request("GET", "/healthz")
        t("vary" not in headers, "other answers have no Vary: %r" % headers.get("vary"))
    shutil.rmtree(tmp)


def test_sighup():
    tmp = tempfile.mkdtemp()
    log = os.path.join(tmp, "rayd.log")
    assignments = os.path.join(tmp, "assignments")
    os.mkdir(assignments)
    shutil.copy("scenes/assignments/phong.cfg", assignments)
    d = Daemon(["--log-file", log, "--assignments", assignments])
    d.request("GET", "/healthz?before=1")
    # The access line is written once the answer has gone out: wait for it,
    # or a slow build may write it after the reopen.
    deadline = time.time() + 5
    while "before=1" not in open(log).read() and time.time() < deadline:
        time.sleep(0.02)
    os.rename(log, log + ".1")
    shutil.copy("scenes/assignments/diffuse.cfg", assignments)
    d.send(signal.SIGHUP)
    deadline = time.time() + 5
    # The new file exists before it replaces stderr; its first line comes after.
    while not (os.path.exists(log) and "SIGHUP" in open(log).read()) and time.time() < deadline:
        time.sleep(0.05)
    d.request("GET", "/healthz?after=1")
    d.stop()
    old = open(log + ".1").read()
    new = open(log).read() if os.path.exists(log) else ""
    t("before=1" in old and "after=1" not in old, "lines before SIGHUP stay in the rotated file")
    t("after=1" in new and "SIGHUP" in new and "stopped" in new, "SIGHUP reopens the log file: %r" % new)
    t(re.search(r"SIGHUP: reloaded.*names=diffuse,phong", new) is not None,
            "SIGHUP reads the assignments again and logs them")
    shutil.rmtree(tmp)


def test_sighup_tokens():
    """SIGHUP reads --instructor-tokens again: a token taken out of the file
    stops working, a new one works, without a restart. A file that became
    bad keeps the tokens read before, and the log says why."""
    tmp = tempfile.mkdtemp()
    tokens = os.path.join(tmp, "tokens")
    old_tok, new_tok = "old-token-0123456789abcdef", "new-token-0123456789abcdef"
    with open(tokens, "w") as f:
        f.write(old_tok + "\n")
    d = Daemon(["--instructor-tokens", tokens])

    def status(tok):
        return d.request("GET", "/v1/grades", headers={"Authorization": "Bearer " + tok})[0]

    def hup(count):
        d.send(signal.SIGHUP)
        deadline = time.time() + 5
        while d.text().count("SIGHUP: reloaded") < count and time.time() < deadline:
            time.sleep(0.02)

    t(status(old_tok) == 200 and status(new_tok) == 403, "before SIGHUP the file's token is the one taken")
    with open(tokens + ".tmp", "w") as f:
        f.write("# rotated\n" + new_tok + "\n")
    os.rename(tokens + ".tmp", tokens)
    hup(1)
    t(status(new_tok) == 200, "after SIGHUP the new token is taken: %d" % status(new_tok))
    t(status(old_tok) == 403, "after SIGHUP the removed token is refused: %d" % status(old_tok))
    t(re.search(r"SIGHUP: instructor tokens read again from \S+tokens: 1 token", d.text()) is not None,
      "SIGHUP logs the tokens' reload: " + d.text()[-400:])
    with open(tokens, "w") as f:
        f.write("short\n")
    hup(2)
    t(status(new_tok) == 200, "a bad file on SIGHUP keeps the tokens read before")
    t(re.search(r"SIGHUP: .*tokens:1: a token is 16 to 256 .*the tokens read before stay", d.text()) is not None,
      "a bad file on SIGHUP is logged with its line: " + d.text()[-400:])
    d.stop()
    shutil.rmtree(tmp)


for test in [test_listen_forms, test_options_and_environment, test_start_checks, test_readyz, test_json_log,
             test_library_messages_in_json, test_text_log_and_proxy, test_per_client_limit, test_caching_headers, test_cors,
             test_verdict_page, test_sighup, test_sighup_tokens]:
    try:
        test()
    except Exception as e:  # one broken feature must not hide the others' results
        t(False, "%s raised %r" % (test.__name__, e))
sys.exit(t.summary())
