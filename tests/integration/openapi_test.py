#!/usr/bin/env python3
"""docs/openapi.json against the daemon.

  - GET /openapi.json is docs/openapi.json, byte for byte;
  - every row of the route table (daemon/http/router.c) is a documented
    path with its methods, and every documented operation is a route;
  - real requests covering every route and the statuses the handlers send
    (200, 202, 400, 404, 405, 409, 413, 415, 422, 431, 503, ...): each
    answer's status is documented for its path and method, its
    Content-Type is one documented for that status, its required headers
    are there, documented headers match their schemas, and a JSON body
    validates against the documented JSON Schema ($refs resolved against
    the document's components);
  - a fixed list of (path, method, status) must have been exercised, so a
    status the test stopped provoking is noticed;
  - the instructor token (securitySchemes/instructorToken) is declared on
    exactly the operations that answer 401/403 on a daemon with
    --instructor-tokens;
  - clients/python/rayd_client.py calls only documented operations, with
    their operationId, method, path, query parameters, form fields and
    token, and its records have the fields of their schemas.

Paths that are documented ahead of the code (/readyz, OPTIONS answered 204
with --cors-origin) are skipped with a note while the daemon answers them
404 or does not know the flag.

Usage: RAYD=build/rayd /usr/bin/python3 tests/integration/openapi_test.py
(from the repository root). Daemons listen on 127.0.0.1 on ports they pick
and are stopped by their pid.
"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

import jsonschema

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "support"))
sys.path.insert(0, os.path.join(HERE, "..", "..", "clients", "python"))
from rayd_http import (RAYD, RUNAWAY_SCENE, TINY_SCENE, Checks, Daemon, form, form_parts, png, render_png, start_runaway,
                       tiny_assignments)
import rayd_client

check = Checks("openapi")
DOC_PATH = "docs/openapi.json"
with open(DOC_PATH, "rb") as f:
    DOC_BYTES = f.read()
DOC = json.loads(DOC_BYTES)
METHODS = ("get", "put", "post", "delete", "options", "head", "patch", "trace")
exercised = set()  # (path template, method, status)
validators = {}


def pointer(parts):
    return "#/" + "/".join(str(p).replace("~", "~0").replace("/", "~1") for p in parts)


def deref(obj):
    """Follows an OpenAPI $ref (within the document) to what it names."""
    while isinstance(obj, dict) and "$ref" in obj:
        node = DOC
        for part in obj["$ref"][2:].split("/"):
            node = node[part.replace("~1", "/").replace("~0", "~")]
        obj = node
    return obj


def schema_errors(ptr, instance):
    """JSON Schema errors of instance against the schema at ptr, $refs
    resolved in the whole document (OpenAPI 3.1 schemas are 2020-12)."""
    if ptr not in validators:
        root = dict(DOC)
        root["$ref"] = ptr
        validators[ptr] = jsonschema.Draft202012Validator(root)
    return ["%s at %s" % (e.message, "/".join(map(str, e.absolute_path)) or "the top")
            for e in validators[ptr].iter_errors(instance)]


def response_of(template, method, status):
    """(the documented response object, its JSON pointer) or (None, None)."""
    op = DOC["paths"].get(template, {}).get(method)
    if op is None:
        return None, None
    r = op["responses"].get(str(status))
    if r is None:
        return None, None
    ptr = r["$ref"] if "$ref" in r else pointer(["paths", template, method, "responses", str(status)])
    return deref(r), ptr


def media_key(content, ctype):
    """The documented media type a Content-Type answers, or None."""
    if ctype in content:
        return ctype
    base = ctype.split(";")[0].strip().lower()
    for key in content:
        if ";" not in key and key.lower() == base:
            return key
    return None


def validate_against(what, resp, ptr, status, headers, body):
    """Checks one answer against one documented response object."""
    for name, h in resp.get("headers", {}).items():
        h = deref(h)
        value = headers.get(name.lower())
        if h.get("required"):
            check(value is not None, "%s: %d lacks the required header %s" % (what, status, name))
        if value is not None and "schema" in h:
            errs = jsonschema.Draft202012Validator(h["schema"]).iter_errors(value)
            for e in errs:
                check(False, "%s: header %s: %r: %s" % (what, name, value, e.message))
    content = resp.get("content")
    ctype = headers.get("content-type")
    if not content:
        check(not body, "%s: %d has a body the document does not describe" % (what, status))
        return
    key = media_key(content, ctype or "")
    if not check(key is not None, "%s: %d Content-Type %r is not one of %s" % (what, status, ctype, list(content))):
        return
    if key.startswith("application/json"):
        try:
            data = json.loads(body)
        except ValueError as e:
            check(False, "%s: %d: the body is not JSON: %s" % (what, status, e))
            return
        errs = schema_errors(ptr + "/content/" + key.replace("~", "~0").replace("/", "~1") + "/schema", data)
        check(not errs, "%s: %d: the body does not match the schema: %s\n  %s" % (what, status, errs[:3],
                                                                                body[:300]))
    elif key.startswith("image/png"):
        check(body.startswith(b"\x89PNG\r\n\x1a\n"), "%s: %d: image/png that is not a PNG" % (what, status))


def validate(template, method, status, headers, body, url):
    """One answer to method url, which the document names template."""
    what = "%s %s" % (method.upper(), url)
    exercised.add((template, method, status))
    if status == 405:
        # No operation answers 405 (it is for a method the document does not
        # list): an Error body with method_not_allowed, X-Request-Id, Allow.
        check("x-request-id" in headers, "%s: 405 without X-Request-Id" % what)
        try:
            data = json.loads(body)
        except ValueError:
            data = None
        check(isinstance(data, dict) and not schema_errors("#/components/schemas/Error", data) and
              data["error"]["code"] == "method_not_allowed", "%s: the 405's body: %s" % (what, body[:200]))
        documented = {m.upper() for m in DOC["paths"].get(template, {}) if m in METHODS and m != "options"}
        allowed = {m.strip() for m in headers.get("allow", "").split(",") if m.strip()}
        check(allowed and allowed <= documented | {"HEAD", "OPTIONS"},
              "%s: Allow %s, the document lists %s" % (what, sorted(allowed), sorted(documented)))
        check(method.upper() not in documented or method == "options",
              "%s: 405 for a documented method" % what)
        return
    resp, ptr = response_of(template, method, status)
    if not check(resp is not None, "%s: status %d is not documented for %s %s" %
                 (what, status, method.upper(), template)):
        return
    validate_against(what, resp, ptr, status, headers, body)


class Client:
    def __init__(self, daemon):
        self.d = daemon

    def call(self, method, template, url=None, body=None, headers=None, expect=None, validate_it=True):
        url = url or template
        status, hdrs, data = self.d.request(method.upper(), url, body=body, headers=headers)
        if expect is not None:
            check(status == expect, "%s %s answered %d, the test expected %d: %s" %
                  (method.upper(), url, status, expect, data[:200]))
        if validate_it:
            validate(template, method, status, hdrs, data, url)
        return status, hdrs, data


# ---- the route table --------------------------------------------------

def route_table():
    """(path, match, methods) of every row of daemon/http/router.c."""
    with open("daemon/http/router.c") as f:
        text = f.read()
    return re.findall(r'\{"(/[^"]*)", RD_ROUTE_(EXACT|BELOW|EXACT_OR_BELOW), "([^"]*)"', text)


def matches(row_path, match, template):
    url = re.sub(r"\{[^}]+\}", "x", template)
    exact = url == row_path
    below = url.startswith(row_path.rstrip("/") + "/") and url != row_path
    return (exact and match != "BELOW") or (below and match != "EXACT")


def check_route_table():
    rows = route_table()
    check(len(rows) >= 10, "read %d rows from router.c" % len(rows))
    documented = {(t, m.upper()) for t, item in DOC["paths"].items() for m in item if m in METHODS and m != "options"}
    for path, match, methods in rows:
        templates = [t for t in DOC["paths"] if matches(path, match, t)]
        check(templates, "router.c's %s (%s) is not documented" % (path, match))
        for m in (x.strip() for x in methods.split(",")):
            check(any((t, m) in documented for t in templates), "router.c's %s %s is not documented" % (m, path))
    for t, m in sorted(documented):
        # The first row that matches is the one the server uses.
        row = next((r for r in rows if matches(r[0], r[1], t)), None)
        if row is None:
            print("openapi: note: %s %s is documented but not in this tree's route table" % (m, t))
            continue
        allowed = row[2]
        if row[0] == "/v1/jobs" and row[1] == "BELOW":
            allowed = "GET" if t.endswith("/image") else "GET, DELETE"  # job_allow in router.c
        check(m in [x.strip() for x in allowed.split(",")] or m == "GET" and "HEAD" in allowed,
              "%s %s is documented but router.c's %s takes %s" % (m, t, row[0], allowed))


def operations():
    """(path template, method, operation) of every documented operation but OPTIONS."""
    return [(t, m, op) for t, item in DOC["paths"].items() for m, op in item.items()
            if m in METHODS and m != "options"]


def needs_token(op):
    """1 when the operation's security (its own, else the document's) asks for the instructor token."""
    return any("instructorToken" in req for req in op.get("security", DOC.get("security", [])))


def check_security_declared():
    """The instructor token is an HTTP bearer scheme, declared on exactly
    the operations that document 401 and 403 (the daemon's instructors'
    routes, daemon/http/routes_batch.c), and nowhere else."""
    scheme = DOC.get("components", {}).get("securitySchemes", {}).get("instructorToken", {})
    check(scheme.get("type") == "http" and scheme.get("scheme") == "bearer",
          "components/securitySchemes/instructorToken is not an HTTP bearer scheme: %r" % scheme)
    check(DOC.get("security") == [], "the document's default security is %r, not [] (open)" % DOC.get("security"))
    for t, m, op in operations():
        answers_401 = "401" in op["responses"] and "403" in op["responses"]
        check(needs_token(op) == answers_401, "%s %s: %s the instructor token but %s 401 and 403" %
              (m.upper(), t, "declares" if needs_token(op) else "does not declare",
               "documents" if answers_401 else "does not document"))
    for t, item in DOC["paths"].items():
        if "options" in item:
            check(not needs_token(item["options"]), "OPTIONS %s declares the instructor token" % t)


def params_of(template, method, where):
    """The names of the operation's parameters that are in `where` (query,
    path), the path item's and its own."""
    item = DOC["paths"][template]
    ps = [deref(p) for p in item.get("parameters", []) + item[method].get("parameters", [])]
    return {p["name"] for p in ps if p.get("in") == where}


def check_client():
    """clients/python/rayd_client.py and the document agree: every
    operation the client calls is documented under its operationId with
    the client's method and path, takes the query parameters and form
    fields the client sends, has the path parameters of its template, and
    needs the instructor token exactly when the client sends it; every
    record's fields are its schema's properties."""
    by_id = {op.get("operationId"): (t, m, op) for t, item in DOC["paths"].items() for m, op in item.items()
             if m in METHODS}
    for oid, cop in rayd_client.OPERATIONS.items():
        if not check(oid in by_id, "the client calls %s, which the document does not have" % oid):
            continue
        t, m, op = by_id[oid]
        check((cop.method, cop.path) == (m.upper(), t), "%s: the client sends %s %s, the document says %s %s" %
              (oid, cop.method, cop.path, m.upper(), t))
        extra = set(cop.query) - params_of(t, m, "query")
        check(not extra, "%s: the client sends query parameters the document does not list: %s" % (oid, extra))
        check(set(re.findall(r"\{([^}]+)\}", cop.path)) == params_of(t, m, "path"),
              "%s: the path parameters differ: %s against %s" % (oid, cop.path, params_of(t, m, "path")))
        if cop.form:
            media = deref(op.get("requestBody", {})).get("content", {}).get("multipart/form-data", {})
            props = set(deref(media.get("schema", {})).get("properties", {}))
            check(set(cop.form) <= props, "%s: the client's form fields %s, the document's %s" %
                  (oid, sorted(cop.form), sorted(props)))
        check(cop.token == needs_token(op), "%s: the client %s the token, the document %s it" %
              (oid, "sends" if cop.token else "does not send", "asks for" if needs_token(op) else "does not ask for"))
    for rec in rayd_client.RECORDS:
        props = set(DOC["components"]["schemas"].get(rec.SCHEMA, {}).get("properties", {}))
        check(props and set(rec.FIELDS) == props, "the client's %s fields %s are not the schema's %s" %
              (rec.__name__, sorted(set(rec.FIELDS) ^ props), rec.SCHEMA))
    names = {p["name"] for p in DOC["paths"]["/v1/render"]["post"]["parameters"] for p in [deref(p)]}
    check(set(rayd_client.OVERRIDES) == names, "the client's overrides %s, POST /v1/render's %s" %
          (sorted(rayd_client.OVERRIDES), sorted(names)))


def check_document():
    check(DOC.get("openapi", "").startswith("3.1."), "openapi is %r" % DOC.get("openapi"))
    check_security_declared()
    refs = re.findall(r'"\$ref": "([^"]+)"', DOC_BYTES.decode())
    for r in set(refs):
        try:
            deref({"$ref": r})
            check(True, r)
        except (KeyError, TypeError):
            check(False, "the $ref %s does not resolve" % r)
    for t, item in DOC["paths"].items():
        for m, op in item.items():
            if m in METHODS:
                check(op.get("responses"), "%s %s has no responses" % (m, t))
                for status, r in op["responses"].items():
                    r = deref(r)
                    for key, media in r.get("content", {}).items():
                        if key.startswith("application/json"):
                            check("schema" in media, "%s %s %s: no schema for JSON" % (m, t, status))
                            jsonschema.Draft202012Validator.check_schema(deref(media["schema"]))


# ---- requests ---------------------------------------------------------

SCENE, RUNAWAY = TINY_SCENE, RUNAWAY_SCENE
CFG = {"Content-Type": "text/x-rayd-cfg"}
MAX_BODY = 65536


def job_state(c, job_id):
    status, _, data = c.call("get", "/v1/jobs/{id}", "/v1/jobs/" + job_id)
    return json.loads(data) if status == 200 else {}


def wait_for(c, job_id, states, timeout=60):
    end = time.time() + timeout
    while time.time() < end:
        st = job_state(c, job_id).get("status")
        if st in states:
            return st
        time.sleep(0.05)
    check(False, "job %s did not reach %s in %d s" % (job_id, states, timeout))
    return None


def submit(c, scene, query="", expect=202):
    status, hdrs, data = c.call("post", "/v1/jobs", "/v1/jobs" + query, scene.encode(), CFG, expect=expect)
    return json.loads(data).get("id", "") if status == 202 else ""


def renders(c):
    R = "/v1/render"
    c.call("post", R, R + "?width=8&height=6&samples=2&max_depth=3&gamma=2.2&seed=7", SCENE.encode(), CFG, 200)
    c.call("post", R, R + "?time_budget_ms=50&target_error=0.5&adaptive=1", SCENE.encode(),
           {"Content-Type": "text/plain"}, 200)
    with open("scenes/phong.json", "rb") as f:
        c.call("post", R, R + "?width=8&height=6", f.read(), {"Content-Type": "application/json"}, 200)
    c.call("post", R, R + "?width=8&height=6", SCENE.encode(), {"Content-Type": "application/octet-stream"}, 200)
    for q in ("?width=0", "?width=wide", "?gamma=0", "?seed=-1", "?target_error=0", "?adaptive=2",
              "?max_depth=65", "?samples=65537"):
        c.call("post", R, R + q, SCENE.encode(), CFG, 400)
    c.call("post", R, R, b"", CFG, 400)
    c.call("post", R, R, b"[render]\nwidth = 64O\n", CFG, 400)
    c.call("post", R, R + "?width=1000&height=1000", SCENE.encode(), CFG, 413)  # --limit-pixels
    c.call("post", R, R, b"#" * (MAX_BODY + 1), CFG, 413)  # --max-body-bytes, refused by Content-Length
    c.call("post", R, R, png(2, 2, lambda x, y: (0, 0, 0)), {"Content-Type": "image/png"}, 415)
    c.call("post", R, R, SCENE.replace("material = m\n", "material = nosuch\n").encode(), CFG, 422)
    c.call("post", R, R, (SCENE + "[mesh]\nfile = nosuch.obj\nmaterial = m\n").encode(), CFG, 422)
    c.call("post", R, R, RUNAWAY.encode(), CFG, 422)  # past --job-timeout-ms: time_limit


def jobs(c):
    J, I = "/v1/jobs/{id}", "/v1/jobs/{id}/image"
    done = submit(c, SCENE, "?width=8&height=6&hdr=1")
    wait_for(c, done, ("done",))
    c.call("get", I, "/v1/jobs/%s/image" % done, expect=200)
    c.call("get", I, "/v1/jobs/%s/image?partial=1" % done, expect=200)
    status, _, _ = c.call("get", I, "/v1/jobs/%s/image" % done, headers={"Accept": "image/x-exr"})
    check(status in (200, 406), "image with Accept: image/x-exr answered %d" % status)
    c.call("delete", J, "/v1/jobs/" + done, expect=200)
    c.call("post", "/v1/jobs", "/v1/jobs?width=0", SCENE.encode(), CFG, 400)
    c.call("post", "/v1/jobs", "/v1/jobs", SCENE.replace("material = m\n", "material = nosuch\n").encode(), CFG, 422)
    c.call("post", "/v1/jobs", "/v1/jobs", b"", CFG, 400)
    c.call("post", "/v1/jobs", "/v1/jobs", b"x", {"Content-Type": "application/pdf"}, 415)
    c.call("post", "/v1/jobs", "/v1/jobs?width=1000&height=1000", SCENE.encode(), CFG, 413)
    # A runaway: running, its image not ready, a partial image, then past its time limit: failed.
    slow = submit(c, RUNAWAY)
    wait_for(c, slow, ("running",))
    c.call("get", I, "/v1/jobs/%s/image" % slow, expect=409)
    c.call("get", I, "/v1/jobs/%s/image?partial=1" % slow, expect=200)
    wait_for(c, slow, ("failed",))
    c.call("get", I, "/v1/jobs/%s/image" % slow, expect=409)
    # Another, cancelled.
    gone = submit(c, RUNAWAY)
    c.call("delete", J, "/v1/jobs/" + gone, expect=200)
    wait_for(c, gone, ("cancelled",))
    c.call("get", I, "/v1/jobs/%s/image" % gone, expect=409)
    for url in ("/v1/jobs/0000000000000000", "/v1/jobs/" + "9" * 40):
        c.call("get", J, url, expect=404)
        c.call("delete", J, url, expect=404)
    c.call("get", I, "/v1/jobs/0000000000000000/image", expect=404)


def grades(c, tmp):
    G = "/v1/grade"
    scene_path = os.path.join(tmp, "small.cfg")
    with open(scene_path, "w") as f:
        f.write(SCENE)
    good = render_png(scene_path, os.path.join(tmp, "small.png"))
    wrong = png(16, 12, lambda x, y: (255, 0, 255))

    def post(fields, expect, ctype=None):
        body, ct = form(fields)
        return c.call("post", G, G, body, {"Content-Type": ctype or ct}, expect)

    status, _, data = post({"scene": SCENE.encode(), "image": good}, 200)
    verdict = json.loads(data) if status == 200 else {}
    check(verdict.get("pass") is True, "the rendered image did not pass: %s" % verdict)
    post({"scene": SCENE.encode(), "image": wrong}, 200)
    status, _, data = post({"assignment": b"tiny", "image": good}, 200)
    recorded = json.loads(data).get("id") if status == 200 else "g" + "f" * 32  # an assignment's grade is a record
    for name in ("diff.png", "reference.png", "image.png"):
        c.call("get", "/v1/grades/{id}/{file}", "/v1/grades/%s/%s" % (verdict.get("id"), name), expect=200)
    # One address, two answers: the page to a browser, the JSON to the rest.
    V = "/v1/grades/{id}"
    for accept, ctype in [(None, "application/json"), ("application/json", "application/json"),
                          ("text/html,application/xhtml+xml,*/*;q=0.8", "text/html; charset=utf-8")]:
        _, h, _ = c.call("get", V, "/v1/grades/" + recorded, headers={"Accept": accept} if accept else None, expect=200)
        check(h.get("content-type") == ctype and h.get("vary") == "Accept",
              "GET /v1/grades/{id} with Accept %r: %r, Vary %r" % (accept, h.get("content-type"), h.get("vary")))
    c.call("get", V, "/v1/grades/g" + "0" * 32, headers={"Accept": "text/html"}, expect=404)
    c.call("get", "/v1/grades/{id}/{file}", "/v1/grades/%s/other.png" % verdict.get("id"), expect=404)
    c.call("get", "/v1/grades/{id}/{file}", "/v1/grades/g0000000000000000/diff.png", expect=404)
    post({"scene": SCENE.encode()}, 400)  # no image
    post({"scene": SCENE.encode(), "assignment": b"tiny", "image": good}, 400)
    post({"assignment": b"x" * 100, "image": good}, 400)
    post({"scene": b"[render]\nwidth = 64O\n", "image": good}, 400)
    post({"assignment": b"nosuch", "image": good}, 404)
    post({"scene": SCENE.encode(), "image": b"\x89PNG" + b"\0" * (MAX_BODY + 10)}, 413)
    post({"scene": SCENE.encode(), "image": good}, 415, ctype="text/plain")
    post({"scene": SCENE.encode(), "image": b"GIF89a......"}, 415)
    post({"scene": SCENE.encode(), "image": good[:60]}, 422)  # bad_image
    post({"scene": SCENE.encode(), "image": png(4, 3, lambda x, y: (0, 0, 0))}, 422)  # size_mismatch
    post({"assignment": b"broken", "image": good}, 422)  # bad_assignment
    post({"scene": SCENE.replace("material = m\n", "material = nosuch\n").encode(), "image": good}, 422)


def code_grades(c):
    """POST /v1/grade/code on the tiny assignment (a diffuse sphere), its
    errors, the skeletons and the lobe plot."""
    G = "/v1/grade/code"
    right = open("tests/codegrade/students/diffuse_ok.h", "rb").read()

    def post(parts, expect, ctype=None):
        body, ct = form_parts(parts)
        return c.call("post", G, G, body, {"Content-Type": ctype or ct}, expect)

    status, _, data = post([("assignment", None, b"tiny"), ("source", "DiffuseMaterial.h", right)], 200)
    v = json.loads(data) if status == 200 else {}
    check(v.get("pass") is True, "diffuse_ok did not pass the tiny assignment: %s" % str(v)[:300])
    c.call("get", "/v1/grade/code/{id}/lobe.svg", v.get("lobe_url") or G + "/x/lobe.svg", expect=200)
    c.call("get", "/v1/grade/code/{id}/lobe.svg", G + "/g0000000000000000/lobe.svg", expect=404)
    c.call("get", "/v1/grade/code/skeleton/{material}", G + "/skeleton/phong", expect=200)
    c.call("get", "/v1/grade/code/skeleton/{material}", G + "/skeleton/mirror", expect=404)
    post([("assignment", None, b"tiny")], 400)
    post([("assignment", None, b"nosuch"), ("source", "DiffuseMaterial.h", right)], 404)
    post([("assignment", None, b"tiny"), ("source", "DiffuseMaterial.h", b"/" * 300000)], 413)
    post([("assignment", None, b"tiny"), ("source", "DiffuseMaterial.h", right)], 415, ctype="text/plain")
    post([("assignment", None, b"tiny"), ("source", "Diffuse Material.exe", right)], 422)  # bad_code
    post([("assignment", None, b"broken"), ("source", "DiffuseMaterial.h", right)], 422)  # bad_assignment
    post([("assignment", None, b"tiny"), ("source", "DiffuseMaterial.h", b"int x = ;\n")], 422)  # compile_error


def class_batch(tmp):
    """The instructors' routes of a daemon with --instructor-tokens."""
    tokens = os.path.join(tmp, "tokens")
    with open(tokens, "w") as f:
        f.write("openapi-instructor-token-0001\n")
    auth = {"Authorization": "Bearer openapi-instructor-token-0001"}
    scene_path = os.path.join(tmp, "small.cfg")
    with open(scene_path, "w") as f:
        f.write(SCENE)
    good = render_png(scene_path, os.path.join(tmp, "small.png"))
    d = Daemon(tmp, ["--threads", "2", "--assignments", tiny_assignments(tmp, broken=True), "--instructor-tokens", tokens])
    try:
        c = Client(d)
        B = "/v1/grade/batch"

        def post(parts, expect, headers=auth):
            body, ct = form_parts(parts)
            return c.call("post", B, B, body, dict(headers, **{"Content-Type": ct}), expect)

        parts = [("assignment", None, b"tiny"), ("image", "ann.png", good), ("image", "ben.png", b"nope")]
        status, _, data = post(parts, 202)
        bid = json.loads(data).get("id", "x") if status == 202 else "x"
        for _ in range(200):
            _, _, data = c.call("get", B + "/{id}", "%s/%s" % (B, bid), headers=auth, expect=200)
            if json.loads(data).get("status") != "running":
                break
            time.sleep(0.05)
        rows = json.loads(data).get("results", [])
        check(len(rows) == 2, "the batch's rows: %s" % rows)
        for table in ("results.csv", "results.json"):
            c.call("get", B + "/{id}/{table}", "%s/%s/%s" % (B, bid, table), headers=auth, expect=200)
        c.call("get", B + "/{id}", B + "/0123456789abcdef", headers=auth, expect=404)
        c.call("get", B + "/{id}", "%s/%s" % (B, bid), expect=401)
        c.call("get", B + "/{id}", "%s/%s" % (B, bid), headers={"Authorization": "Bearer wrong-wrong-wrong-1"},
               expect=403)
        post(parts, 401, headers={})
        post(parts, 403, headers={"Authorization": "Bearer wrong-wrong-wrong-1"})
        post([("image", "ann.png", good)], 400)
        post([("assignment", None, b"nosuch"), ("image", "ann.png", good)], 404)
        post([("assignment", None, b"broken"), ("image", "ann.png", good)], 422)
        c.call("post", B, B, b"x", dict(auth, **{"Content-Type": "text/plain"}), 415)
        c.call("get", "/v1/grades", "/v1/grades?assignment=tiny", headers=auth, expect=200)
        c.call("get", "/v1/grades", "/v1/grades?student=ann", headers=dict(auth, Accept="text/csv"), expect=200)
        c.call("get", "/v1/grades", "/v1/grades?since=soon", headers=auth, expect=400)
        c.call("get", "/v1/grades", "/v1/grades", expect=401)
        c.call("get", "/v1/grades", "/v1/grades", headers={"Authorization": "Bearer wrong-wrong-wrong-1"}, expect=403)
        for r in rows:
            c.call("get", "/v1/grades/{id}", "/v1/grades/" + r.get("grade_id", "x"), expect=200)
        c.call("get", "/v1/grades/{id}", "/v1/grades/g0000000000000000", expect=404)
        manage(c, post, auth, rows, good)
        check_security_answered(c, bid, rows[0].get("grade_id", "x") if rows else "x", auth)
    finally:
        check(d.stop() == 0, "the instructors' daemon did not exit 0")


def manage(c, post, auth, rows, good):
    """Listing batches, cancelling a running one and deleting it, deleting
    a student's records and one record."""
    B = "/v1/grade/batch"
    c.call("get", B, B, headers=auth, expect=200)
    c.call("get", B, B + "?assignment=tiny&limit=5&until=2100-01-01T00:00:00.000Z", headers=auth, expect=200)
    c.call("get", B, B + "?limit=0", headers=auth, expect=400)
    # Deleted as soon as it is posted, 200 images in: still running.
    status, _, data = post([("assignment", None, b"tiny")] + [("image", "s%d.png" % i, good) for i in range(200)], 202)
    big = json.loads(data).get("id", "x") if status == 202 else "x"
    c.call("delete", B + "/{id}", "%s/%s" % (B, big), headers=auth, expect=200)
    c.call("delete", B + "/{id}", "%s/%s" % (B, big), headers=auth, expect=204)
    c.call("delete", B + "/{id}", "%s/%s" % (B, big), headers=auth, expect=404)
    c.call("delete", "/v1/grades", "/v1/grades?student=ben", headers=auth, expect=200)
    c.call("delete", "/v1/grades", "/v1/grades", headers=auth, expect=400)
    ann = [r.get("grade_id", "x") for r in rows if r.get("student") == "ann"]
    c.call("delete", "/v1/grades/{id}", "/v1/grades/" + (ann or ["x"])[0], headers=auth, expect=204)
    c.call("delete", "/v1/grades/{id}", "/v1/grades/g0000000000000000", headers=auth, expect=404)


def check_security_answered(c, bid, gid, auth):
    """On a daemon with --instructor-tokens, every operation: the ones
    declaring the instructor token answer 401 without one and 403 with a
    wrong one, and not 401 with the right one; no other answers 401."""
    values = {"id": bid, "table": "results.json", "file": "diff.png", "material": "phong", "name": "tiny"}
    for t, m, op in operations():
        if t.startswith("/v1/grades/") or t.startswith("/v1/grade/code/{id}"):
            values["id"] = gid
        elif t.startswith("/v1/jobs/"):
            values["id"] = "0" * 32
        else:
            values["id"] = bid
        url = re.sub(r"\{([^}]+)\}", lambda g: values[g.group(1)], t)
        body = b"" if m in ("post", "put") else None
        status, _, _ = c.call(m, t, url, body=body)
        if needs_token(op):
            check(status == 401, "%s %s without a token answered %d, not 401" % (m.upper(), url, status))
            status, _, _ = c.call(m, t, url, body=body, headers={"Authorization": "Bearer wrong-wrong-wrong-1"})
            check(status == 403, "%s %s with a wrong token answered %d, not 403" % (m.upper(), url, status))
            status, _, _ = c.call(m, t, url, body=body, headers=auth)
            check(status not in (401, 403), "%s %s with the token answered %d" % (m.upper(), url, status))
        else:
            check(status != 401, "%s %s answered 401 but declares no security" % (m.upper(), url))


def listings(c):
    c.call("get", "/v1/assignments", expect=200)
    c.call("get", "/v1/assignments/{name}", "/v1/assignments/tiny", expect=200)
    c.call("get", "/v1/assignments/{name}/scene", "/v1/assignments/tiny/scene", expect=200)
    c.call("get", "/v1/assignments/{name}/scene", "/v1/assignments/nosuch/scene", expect=404)
    c.call("get", "/v1/assignments/{name}", "/v1/assignments/nosuch", expect=404)
    c.call("get", "/v1/scenes", expect=200)
    c.call("get", "/v1/scenes/{name}", "/v1/scenes/phong", expect=200)
    c.call("get", "/v1/scenes/{name}", "/v1/scenes/phong.cfg", expect=200)
    c.call("get", "/v1/scenes/{name}", "/v1/scenes/phong.json", expect=200)
    c.call("get", "/v1/scenes/{name}", "/v1/scenes/nosuch", expect=404)
    c.call("get", "/v1/scenes/{name}", "/v1/scenes/..%2Fphong.cfg", expect=404)
    c.call("get", "/healthz", expect=200)
    c.call("get", "/metrics", expect=200)
    c.call("get", "/", expect=200)
    c.call("get", "/index.html", expect=200)
    status, _, data = c.call("get", "/openapi.json", expect=200)
    check(data == DOC_BYTES, "GET /openapi.json is not docs/openapi.json (rebuild after editing it)")
    status, hdrs, data = c.d.request("GET", "/readyz")
    if status == 404:
        print("openapi: note: GET /readyz answers 404 in this tree; not validated")
    else:
        validate("/readyz", "get", status, hdrs, data, "/readyz")


def wrong_methods(c):
    for method, template, url in (("post", "/healthz", "/healthz"), ("get", "/v1/render", "/v1/render"),
                                  ("get", "/v1/jobs", "/v1/jobs"), ("put", "/v1/jobs/{id}", "/v1/jobs/x"),
                                  ("delete", "/v1/jobs/{id}/image", "/v1/jobs/x/image"),
                                  ("post", "/metrics", "/metrics"), ("delete", "/v1/scenes", "/v1/scenes"),
                                  ("get", "/v1/grade", "/v1/grade")):
        c.call(method, template, url, body=b"" if method in ("post", "put") else None, expect=405)
    c.call("get", "/healthz", "/healthz?" + "&".join("a%d=1" % i for i in range(70)), expect=431)
    status, hdrs, data = c.d.request("GET", "/no/such/route")
    check(status == 404 and not schema_errors("#/components/schemas/Error", json.loads(data)),
          "an undocumented path: %d %s" % (status, data[:200]))


def options(c):
    """OPTIONS on every path: 204 with Allow, and no CORS header without --cors-origin."""
    for template in DOC["paths"]:
        url = re.sub(r"\{[^}]+\}", "x", template)
        status, hdrs, data = c.call("options", template, url, expect=204)
        check("access-control-allow-origin" not in hdrs and "allow" in hdrs,
              "OPTIONS %s without --cors-origin: Allow and no CORS header: %r" % (url, hdrs))


def cors(tmp):
    d = Daemon(tmp, ["--threads", "1", "--cors-origin", "http://example.test"])
    try:
        c = Client(d)
        for template in DOC["paths"]:
            url = re.sub(r"\{[^}]+\}", "x", template)
            status, hdrs, data = c.call("options", template, url, headers={
                "Origin": "http://example.test", "Access-Control-Request-Method": "GET"}, expect=204)
            check(hdrs.get("access-control-allow-origin") == "http://example.test" and
                  "access-control-allow-methods" in hdrs, "OPTIONS %s: the preflight headers: %r" % (url, hdrs))
    finally:
        check(d.stop() == 0, "the CORS daemon did not exit 0")


def small_limits(tmp):
    """A queue of one (503 queue_full) and results kept one second (404 expired)."""
    d = Daemon(tmp, ["--threads", "1", "--queue", "1", "--result-ttl", "1", "--lease-ms", "500",
                     "--job-timeout-ms", "20000"])
    try:
        c = Client(d)
        slow = submit(c, RUNAWAY)
        wait_for(c, slow, ("running",))
        c.call("post", "/v1/render", "/v1/render", SCENE.encode(), CFG, 503)
        c.call("post", "/v1/jobs", "/v1/jobs", SCENE.encode(), CFG, 503)
        body, ct = form({"scene": SCENE.encode(), "image": png(16, 12, lambda x, y: (0, 0, 0))})
        c.call("post", "/v1/grade", "/v1/grade", body, {"Content-Type": ct}, 503)
        c.call("delete", "/v1/jobs/{id}", "/v1/jobs/" + slow, expect=200)
        wait_for(c, slow, ("cancelled",))
        done = submit(c, SCENE)
        wait_for(c, done, ("done",))
        time.sleep(3)  # past --result-ttl and the store's next sweep
        c.call("get", "/v1/jobs/{id}/image", "/v1/jobs/%s/image" % done, expect=404)  # expired
    finally:
        check(d.stop() == 0, "the small daemon did not exit 0")


def per_client(tmp):
    """--max-per-ip behind a trusted proxy: a client with a request open
    gets 429 too_many_requests on any route, OPTIONS included."""
    d = Daemon(tmp, ["--threads", "1", "--trust-proxy", "127.0.0.1", "--max-per-ip", "1",
                     "--job-timeout-ms", "20000", "--drain-ms", "100"])
    who = {"X-Forwarded-For": "192.0.2.7"}
    try:
        c = Client(d)

        start_runaway(d, dict(CFG, **who))
        c.call("get", "/healthz", headers=who, expect=429)
        c.call("options", "/healthz", headers=who, expect=429)
        c.call("post", "/v1/jobs", "/v1/jobs", SCENE.encode(), dict(CFG, **who), 429)
        c.call("get", "/healthz", headers={"X-Forwarded-For": "192.0.2.8"}, expect=200)
    finally:
        check(d.stop() == 0, "the per-client daemon did not exit 0")


def draining(d, c):
    """SIGTERM while a synchronous render runs: new work gets 503 draining
    until it ends (a stored job would not hold the daemon: it resumes)."""
    start_runaway(d, CFG)
    d.terminate()
    time.sleep(0.3)
    c.call("post", "/v1/render", "/v1/render", SCENE.encode(), CFG, 503)
    c.call("post", "/v1/jobs", "/v1/jobs", SCENE.encode(), CFG, 503)
    body, ct = form({"scene": SCENE.encode(), "image": png(16, 12, lambda x, y: (0, 0, 0))})
    c.call("post", "/v1/grade", "/v1/grade", body, {"Content-Type": ct}, 503)
    body, ct = form_parts([("assignment", None, b"tiny"), ("source", "DiffuseMaterial.h", b"int x;")])
    c.call("post", "/v1/grade/code", "/v1/grade/code", body, {"Content-Type": ct}, 503)
    status, _, _ = c.call("get", "/readyz", validate_it=False)
    if status != 404:
        c.call("get", "/readyz", expect=503)


# What the test must have provoked: a status it stops provoking fails it.
REQUIRED = {
    ("/v1/render", "post"): {200, 400, 413, 415, 422, 503},
    ("/v1/jobs/{id}", "get"): {200, 404}, ("/v1/jobs/{id}", "delete"): {200, 404},
    ("/v1/jobs/{id}/image", "get"): {200, 404, 409},
    ("/v1/grade", "post"): {200, 400, 404, 413, 415, 422, 503},
    ("/v1/assignments", "get"): {200}, ("/v1/assignments/{name}", "get"): {200, 404},
    ("/v1/assignments/{name}/scene", "get"): {200, 404}, ("/v1/grades/{id}/{file}", "get"): {200, 404},
    ("/v1/scenes", "get"): {200}, ("/v1/scenes/{name}", "get"): {200, 404},
    ("/healthz", "get"): {200, 429, 431}, ("/healthz", "options"): {204, 429}, ("/healthz", "post"): {405},
    ("/v1/jobs", "post"): {202, 400, 413, 415, 422, 429, 503}, ("/metrics", "get"): {200},
    ("/metrics", "post"): {405}, ("/v1/jobs", "get"): {405}, ("/v1/jobs/{id}/image", "delete"): {405},
    ("/openapi.json", "get"): {200},
    ("/", "get"): {200}, ("/index.html", "get"): {200},
    ("/v1/grade/batch", "post"): {202, 400, 401, 403, 404, 415, 422},
    ("/v1/grade/batch/{id}", "get"): {200, 401, 403, 404}, ("/v1/grade/batch/{id}/{table}", "get"): {200},
    ("/v1/grades", "get"): {200, 400, 401, 403}, ("/v1/grades/{id}", "get"): {200, 404},
    ("/v1/grade/batch", "get"): {200, 400, 401, 403}, ("/v1/grade/batch/{id}", "delete"): {200, 204, 401, 403, 404},
    ("/v1/grades", "delete"): {200, 400, 401, 403}, ("/v1/grades/{id}", "delete"): {204, 401, 403, 404},
    ("/v1/grade/code", "post"): {200, 400, 404, 413, 415, 422, 503},
    ("/v1/grade/code/skeleton/{material}", "get"): {200, 404}, ("/v1/grade/code/{id}/lobe.svg", "get"): {200, 404},
}


def check_coverage():
    for (template, method), statuses in REQUIRED.items():
        seen = {s for t, m, s in exercised if t == template and m == method}
        missing = statuses - seen
        check(not missing, "%s %s: statuses %s were not exercised" % (method.upper(), template, sorted(missing)))
    for template, item in DOC["paths"].items():
        for m in item:
            if m in METHODS and m != "options" and template != "/readyz":
                check(any(t == template and mm == m for t, mm, _ in exercised),
                      "%s %s was never requested" % (m.upper(), template))


def main():
    check_document()
    check_route_table()
    check_client()
    tmp = tempfile.mkdtemp(prefix="rayd-openapi-")
    flags = ["--threads", "2", "--max-body-bytes", str(MAX_BODY), "--limit-pixels", "100000",
             "--job-timeout-ms", "1500", "--drain-ms", "20000", "--assignments", tiny_assignments(tmp, broken=True)]
    d = Daemon(tmp, flags)
    try:
        c = Client(d)
        listings(c)
        renders(c)
        jobs(c)
        grades(c, tmp)
        code_grades(c)
        wrong_methods(c)
        options(c)
        draining(d, c)
    finally:
        rc = d.stop()
        check(rc == 0, "the daemon exited %d after SIGTERM" % rc)
    for sub in ("small", "cors", "class", "per_client"):
        os.makedirs(os.path.join(tmp, sub))
    small_limits(os.path.join(tmp, "small"))
    cors(os.path.join(tmp, "cors"))
    class_batch(os.path.join(tmp, "class"))
    per_client(os.path.join(tmp, "per_client"))
    check_coverage()
    if not check.failed:
        shutil.rmtree(tmp, ignore_errors=True)
    return check.summary()


if __name__ == "__main__":
    sys.exit(main())
