"""What the stored-job tests (store_test.py, farm_test.py) share: the query
of a job's overrides, its status and image as a test reads them, waiting for
jobs to end, and comparing an image's pixels with `rayd render`'s."""

import json
import sys
import time

from rayd_http import decode_png

ENDED = ("done", "failed", "cancelled")


def query(overrides):
    """{"width": 160, ...} as a query string."""
    return "&".join("%s=%s" % kv for kv in overrides.items())


def status_json(status, body):
    """A GET /v1/jobs/ID answer as a dict; {"status": "http 404"} and the
    like when it is not a job's status."""
    if status != 200:
        return {"status": "http %d" % status, "body": body[:200]}
    try:
        return json.loads(body)
    except ValueError:
        return {"status": "not JSON", "body": body[:200]}


def png_body(status, headers, body):
    """A GET /v1/jobs/ID/image answer's PNG, or None."""
    if status == 200 and headers.get("content-type", "").startswith("image/png"):
        return body
    return None


def wait_done(check, poll, ids, timeout, what):
    """Polls poll(id) (a status dict) until every job has ended or is gone;
    their last statuses, one failed check for those not done."""
    deadline, last = time.time() + timeout, {}
    while True:
        last = {jid: poll(jid) for jid in ids}
        if all(s.get("status") in ENDED or s.get("status", "").startswith("http 404") for s in last.values()) \
                or time.time() > deadline:
            break
        time.sleep(0.1)
    left = {jid: s.get("status") for jid, s in last.items() if s.get("status") != "done"}
    check(not left, "%s: %d of %d jobs are not done after %.0f s: %s" %
          (what, len(left), len(ids), timeout, dict(list(left.items())[:5])))
    for jid, s in last.items():
        if s.get("status") == "failed":
            print("  job %s failed: %s" % (jid, s.get("error")), file=sys.stderr)
    return last


def same_pixels(check, png_bytes, ref, what):
    """ref: decode_png of `rayd render`'s PNG."""
    if png_bytes is None:
        return check(False, "%s: no PNG" % what)
    try:
        got = decode_png(png_bytes)
    except ValueError as e:
        return check(False, "%s: the PNG does not decode: %s" % (what, e))
    if got[:2] != ref[:2]:
        return check(False, "%s: %dx%d, the CLI's is %dx%d" % (what, got[0], got[1], ref[0], ref[1]))
    diff = sum(1 for a, b in zip(got[2], ref[2]) if a != b)
    return check(got[2] == ref[2], "%s: %d of %d samples differ from `rayd render`'s" % (what, diff, len(ref[2])))
