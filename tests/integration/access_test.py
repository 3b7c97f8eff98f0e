"""Who may read, list and cancel what (docs/access.md): every id that
grants access is 128 random bits, so one's own ids say nothing of anyone
else's. Renders, grades and batches are made, their ids checked for form
and for the structure a counter would leave (the SplitMix64 inversion that
once found 252 classmates' grades from one id), their neighbours asked
for without a token, and the instructors' routes without one.

Run: RAYD=build/rayd python3 tests/integration/access_test.py"""
import json
import os
import re
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "support"))
from rayd_http import Checks, Daemon, form_parts, png  # noqa: E402

check = Checks("access")
TOKEN = "access-token-0123456789abcdef"
AUTH = {"Authorization": "Bearer " + TOKEN}
M = (1 << 64) - 1
SCENE = open("scenes/phong.cfg").read().encode()
SMALL = "?width=8&height=8&samples=1"


def mix(z):
    z = (z + 0x9E3779B97F4A7C15) & M
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M
    return z ^ (z >> 31)


def unxorshift(z, s):
    x = z
    for _ in range(64 // s + 1):
        x = z ^ (x >> s)
    return x & M


def unmix(y):
    z = unxorshift(y, 31)
    z = (z * pow(0x94D049BB133111EB, -1, 1 << 64)) & M
    z = unxorshift(z, 27)
    z = (z * pow(0xBF58476D1CE4E5B9, -1, 1 << 64)) & M
    z = unxorshift(z, 30)
    return (z - 0x9E3779B97F4A7C15) & M


def neighbours(ident, kind, n=256):
    """The ids a counter mixed with one key would have given next to this
    one, in this id's own form."""
    digits = ident[len(kind):]
    x = unmix(int(digits[:16], 16))
    return [kind + ("%016x" % mix(x ^ m)) + digits[16:] for m in range(1, n)]


def unrelated(ids, kind, what):
    """No id is among another's counter neighbours."""
    seen = set(ids)
    hits = [c for i in ids for c in neighbours(i, kind) if c in seen]
    check(not hits, "%s: ids predictable from one another: %s" % (what, hits[:3]))


def well_formed(ids, kind, what):
    pattern = re.compile("^" + kind + "[0-9a-f]{32}$")
    bad = [i for i in ids if not pattern.match(i)]
    check(not bad, "%s: ids not %s and 32 hex digits (128 bits): %s" % (what, kind or "", bad[:3]))
    check(len(set(ids)) == len(ids), "%s: an id given twice" % what)


def renders(d, n):
    ids = []
    for _ in range(n):
        st, h, _ = d.request("POST", "/v1/render" + SMALL, body=SCENE)
        check(st == 200, "a render answers 200 (%d)" % st)
        ids.append(h.get("x-rayd-job", ""))
    return ids


def grade(d, student):
    body, ct = form_parts([("assignment", None, b"phong"), ("student", None, student.encode()),
                           ("image", "x.png", png(320, 240, lambda x, y: (x % 256, y % 256, 0)))])
    st, _, b = d.request("POST", "/v1/grade", body=body, headers={"Content-Type": ct})
    v = json.loads(b) if b else {}
    check(st == 200 and isinstance(v.get("id"), str), "a grade answers 200 with an id (%d %r)" % (st, b[:200]))
    return v.get("id", "")


def test_render_ids(d):
    ids = renders(d, 24)
    well_formed(ids, "", "renders")
    unrelated(ids, "", "renders")
    # What the attacker did: DELETE the ids next to one's own.
    codes = set()
    for c in neighbours(ids[-1], "", 64):
        st, _, _ = d.request("DELETE", "/v1/jobs/" + c)
        codes.add(st)
    check(codes == {404}, "DELETE of the ids next to one's own: only 404 (%s)" % sorted(codes))
    st, _, b = d.request("GET", "/v1/jobs/" + ids[0])
    check(st == 200 and json.loads(b).get("status") == "done", "one's own render is there (%d)" % st)


def test_grade_ids(d):
    ids = [grade(d, s) for s in ("alice", "bob", "mallory", "carol", "dave")]
    well_formed(ids, "g", "grades")
    unrelated(ids, "g", "grades")
    found = []
    for c in neighbours(ids[2], "g"):
        st, _, b = d.request("GET", "/v1/grades/" + c)
        if st != 404:
            found.append((c, st))
    check(not found, "mallory's neighbours answer: %s" % found[:3])
    for path in ("/v1/grades/" + ids[0], "/v1/grades/" + ids[0] + "/diff.png"):
        st, _, _ = d.request("GET", path)
        check(st == 200, "the holder of an id reads %s (%d)" % (path, st))
    # An id in any other form was never one.
    for other in (ids[0][:17], ids[0].upper(), ids[0] + "0", ids[0][1:]):
        st, _, _ = d.request("GET", "/v1/grades/" + other)
        check(st == 404, "GET /v1/grades/%s is 404 (%d)" % (other, st))
    # Listing the records is the instructors'.
    st, _, _ = d.request("GET", "/v1/grades?assignment=phong")
    check(st == 401, "GET /v1/grades without a token is 401 (%d)" % st)
    st, _, b = d.request("GET", "/v1/grades?assignment=phong", headers=AUTH)
    listed = {g.get("student") for g in json.loads(b).get("grades", [])} if st == 200 else set()
    check({"alice", "bob", "mallory", "carol", "dave"} <= listed, "the instructors list every record (%d, %s)" % (st, listed))


def test_batch_ids(d):
    bids = []
    for i in range(4):
        body, ct = form_parts([("assignment", None, b"phong"),
                               ("image", "s%d.png" % i, png(320, 240, lambda x, y: (0, 0, 0)))])
        st, _, b = d.request("POST", "/v1/grade/batch", body=body, headers=dict(AUTH, **{"Content-Type": ct}))
        check(st == 202, "a batch is accepted (%d %r)" % (st, b[:200]))
        bids.append(json.loads(b).get("id", "") if st == 202 else "")
    well_formed(bids, "", "batches")
    unrelated(bids, "", "batches")


def test_stored_job_ids(d):
    ids = []
    for _ in range(6):
        st, _, b = d.request("POST", "/v1/jobs" + SMALL, body=SCENE)
        check(st == 202, "a stored job is accepted (%d)" % st)
        ids.append(json.loads(b).get("id", "") if st == 202 else "")
    well_formed(ids, "", "stored jobs")
    unrelated(ids, "", "stored jobs")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        tokens = os.path.join(tmp, "tokens")
        with open(tokens, "w") as f:
            f.write(TOKEN + "\n")
        with Daemon(tmp, ["--instructor-tokens", tokens, "--threads", "2"]) as d:
            test_render_ids(d)
            test_grade_ids(d)
            test_batch_ids(d)
            test_stored_job_ids(d)
    return check.summary()


if __name__ == "__main__":
    sys.exit(main())
