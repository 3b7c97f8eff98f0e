"""A client of rayd's HTTP API (docs/openapi.json), Python 3 standard library only.

    from rayd_client import Client
    c = Client("http://127.0.0.1:8080")
    r = c.render(open("scenes/phong.cfg").read(), width=320, height=240)
    open("phong.png", "wb").write(r.image)              # r.job_id, r.samples, r.render_ms ...
    job = c.wait(c.submit(scene_text, samples=16).id)   # a stored job, polled until it ends
    png = c.image(job.id)
    v = c.grade(png, assignment="phong")                # a Verdict: v.pass_, v.metrics, v.id
    g = c.grade_code(open("PhongMaterial.h", "rb").read(), assignment="phong")
    teacher = Client("http://127.0.0.1:8080", token="the instructor's token")
    b = teacher.wait_batch(teacher.grade_batch("phong", images={"ann": png}).id)
    rows = teacher.grades(assignment="phong")           # GradeRow records

Functions (each one operation of the document, named by its operationId in
OPERATIONS below, which tests/integration/openapi_test.py checks against
docs/openapi.json: method, path, query parameters, form fields and whether
the instructor token is needed, so the two cannot drift apart):

  render(scene, **overrides)       POST /v1/render           -> Render (the image and X-Rayd-* figures)
  submit(scene, hdr=, **overrides) POST /v1/jobs             -> Job (queued)
  job(id), wait(id)                GET /v1/jobs/{id}         -> Job (wait: until done, failed or cancelled)
  image(id, partial=, exr=)        GET /v1/jobs/{id}/image   -> bytes
  cancel(id)                       DELETE /v1/jobs/{id}      -> Job
  grade(image, assignment=|scene=, student=)  POST /v1/grade -> Verdict
  grade_record(id), grade_file(id, name)      GET /v1/grades/{id}[/{file}] -> Verdict, bytes
  grade_code(source, assignment, filename=, student=)  POST /v1/grade/code -> CodeGrade
  skeleton(material), lobe(id)     GET /v1/grade/code/...    -> str (the header, the SVG)
  grade_batch(assignment, images=|archive=)   POST /v1/grade/batch (token) -> Batch
  batch(id), wait_batch(id), batch_table(id, "csv"|"json")   GET /v1/grade/batch/{id}[/{table}] (token)
  grades(assignment=, student=, since=)       GET /v1/grades (token) -> [GradeRow]; grades_csv(..., excel=) -> str
  gradebook(format, excel=False)              GET /v1/gradebook (token) -> str: Moodle's or Canvas's CSV
  regrade(assignment)                         POST /v1/grade/regrade (token) -> Batch
  batches(assignment=, until=, limit=)       GET /v1/grade/batch (token) -> [BatchSummary], newest first
  delete_batch(id)                 DELETE /v1/grade/batch/{id} (token) -> Batch (cancelled), or None (deleted)
  delete_student(student)          DELETE /v1/grades?student= (token) -> how many records went
  delete_grade(id)                 DELETE /v1/grades/{id} (token)
  assignments(), scenes(), scene(name), assignment_scene(name), health(), ready()

The records (Job, Verdict, CodeGrade, Batch, BatchSummary, GradeRow) are dicts of the
JSON answer as the document's schema of that name describes it, whose
properties are also attributes (`job.status`); a property that is a Python
keyword takes a trailing `_` (`verdict.pass_`, `code_grade.class_`). Their
FIELDS are the schema's properties, checked against the document.

An answer that is not 2xx raises RaydError with its status, the error's
code and message (and line, column for a scene's syntax), and Retry-After.
"""
import json
import time
import urllib.error
import urllib.parse
import urllib.request
import uuid

__all__ = ["Client", "RaydError", "Render", "Job", "Verdict", "CodeGrade", "Batch", "BatchSummary", "GradeRow",
           "OPERATIONS", "OVERRIDES"]

# The query parameters of POST /v1/render and POST /v1/jobs that override a scene's [render] keys.
OVERRIDES = ("width", "height", "samples", "max_depth", "gamma", "seed", "time_budget_ms", "target_error",
             "adaptive")


class Operation:
    """One operation of docs/openapi.json as this client calls it."""

    def __init__(self, method, path, query=(), form=(), token=False):
        self.method, self.path, self.query, self.form, self.token = method, path, tuple(query), tuple(form), token

    def __repr__(self):
        return "Operation(%s %s)" % (self.method, self.path)


# operationId -> what the client sends. Every request goes through this table.
OPERATIONS = {
    "render": Operation("POST", "/v1/render", OVERRIDES),
    "submitJob": Operation("POST", "/v1/jobs", OVERRIDES + ("hdr",)),
    "getJob": Operation("GET", "/v1/jobs/{id}"),
    "getJobImage": Operation("GET", "/v1/jobs/{id}/image", ("partial",)),
    "cancelJob": Operation("DELETE", "/v1/jobs/{id}"),
    "grade": Operation("POST", "/v1/grade", form=("image", "assignment", "scene", "student")),
    "getGrade": Operation("GET", "/v1/grades/{id}"),
    "getGradeImage": Operation("GET", "/v1/grades/{id}/{file}"),
    "gradeCode": Operation("POST", "/v1/grade/code", form=("assignment", "source", "student")),
    "getCodeSkeleton": Operation("GET", "/v1/grade/code/skeleton/{material}"),
    "getCodeLobe": Operation("GET", "/v1/grade/code/{id}/lobe.svg"),
    "gradeBatch": Operation("POST", "/v1/grade/batch", form=("assignment", "student", "image", "archive"),
                            token=True),
    "getGradeBatch": Operation("GET", "/v1/grade/batch/{id}", token=True),
    "getGradeBatchTable": Operation("GET", "/v1/grade/batch/{id}/{table}", ("excel",), token=True),
    "listGrades": Operation("GET", "/v1/grades", ("assignment", "student", "since", "excel"), token=True),
    "getGradebook": Operation("GET", "/v1/gradebook", ("format", "excel"), token=True),
    "regradeAssignment": Operation("POST", "/v1/grade/regrade", ("assignment",), token=True),
    "listGradeBatches": Operation("GET", "/v1/grade/batch", ("assignment", "until", "limit"), token=True),
    "deleteGradeBatch": Operation("DELETE", "/v1/grade/batch/{id}", token=True),
    "deleteStudentGrades": Operation("DELETE", "/v1/grades", ("student",), token=True),
    "deleteGrade": Operation("DELETE", "/v1/grades/{id}", token=True),
    "listAssignments": Operation("GET", "/v1/assignments"),
    "getAssignmentSceneFile": Operation("GET", "/v1/assignments/{name}/scene"),
    "listScenes": Operation("GET", "/v1/scenes"),
    "getScene": Operation("GET", "/v1/scenes/{name}"),
    "health": Operation("GET", "/healthz"),
    "ready": Operation("GET", "/readyz"),
}


class RaydError(Exception):
    """A non-2xx answer: status, code (error.code), message, line and column
    (a scene's syntax error), retry_after (seconds, or None), body (bytes)."""

    def __init__(self, status, body, headers):
        self.status, self.body, self.headers = status, body, headers
        err = {}
        try:
            err = json.loads(body.decode("utf-8")).get("error", {})
        except (ValueError, AttributeError, UnicodeDecodeError):
            pass
        self.code = err.get("code")
        self.message = err.get("message", body[:200].decode("utf-8", "replace"))
        self.line, self.column = err.get("line"), err.get("column")
        ra = headers.get("Retry-After")
        self.retry_after = int(ra) if ra and ra.isdigit() else None
        super().__init__("%d %s: %s" % (status, self.code or "error", self.message))


class Record(dict):
    """A JSON object of the answer; SCHEMA names its schema in the document
    (components/schemas), FIELDS are that schema's properties."""

    SCHEMA = None
    FIELDS = ()

    def __getattr__(self, name):
        key = name[:-1] if name.endswith("_") else name
        if key in self.FIELDS:
            return self.get(key)
        raise AttributeError("%s has no field %r" % (type(self).__name__, name))


class Job(Record):
    SCHEMA = "Job"
    FIELDS = ("id", "status", "progress", "elapsed_ms", "queued_ms", "samples", "error_estimate", "width", "height",
              "curve", "passes", "stopped_by", "stats", "error")


class Verdict(Record):
    SCHEMA = "Verdict"
    FIELDS = ("assignment", "title", "pass", "width", "height", "metrics", "thresholds", "worst", "failed_box",
              "reference_cached", "id", "diff_url", "reference_url", "image_url", "record")


class CodeGrade(Record):
    SCHEMA = "CodeGrade"
    FIELDS = ("id", "student", "assignment", "material", "class", "pass", "compile", "function", "image",
              "shading_calls", "lobe_url", "diff_url", "output", "note", "ms", "sandbox_ms", "record")


class GradeRow(Record):
    SCHEMA = "GradeRow"
    FIELDS = ("student", "assignment", "pass", "failed_fraction", "max_abs", "psnr_db", "ssim", "graded_at", "error",
              "grade_id", "url", "kind", "counts", "submitted_at", "late", "score", "points", "on_roster", "regrade_of")


class Batch(Record):
    SCHEMA = "Batch"
    FIELDS = ("id", "assignment", "status", "total", "done", "created_at", "results")

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        if isinstance(self.get("results"), list):
            self["results"] = [GradeRow(r) for r in self["results"]]


class BatchSummary(Record):
    SCHEMA = "BatchSummary"
    FIELDS = ("id", "assignment", "status", "total", "done", "created_at")


RECORDS = (Job, Verdict, CodeGrade, GradeRow, Batch, BatchSummary)


class Render:
    """POST /v1/render's answer: image (PNG, or EXR when asked), content_type,
    job_id (X-Rayd-Job: GET /v1/jobs/{id} reads its status), and the figures
    of its X-Rayd-* headers: render_ms, samples, error_estimate, stopped_by,
    passes."""

    def __init__(self, image, headers):
        self.image, self.headers = image, headers
        self.content_type = headers.get("Content-Type")
        self.job_id = headers.get("X-Rayd-Job")

        def num(name, kind):
            v = headers.get(name)
            try:
                return kind(v) if v is not None else None
            except ValueError:
                return None

        self.render_ms = num("X-Rayd-Render-Ms", float)
        self.samples = num("X-Rayd-Samples", int)
        self.error_estimate = num("X-Rayd-Error-Estimate", float)
        self.passes = num("X-Rayd-Passes", int)
        self.stopped_by = headers.get("X-Rayd-Stopped-By")


def _multipart(parts):
    """parts: (name, filename or None, bytes or str) -> (body, Content-Type)."""
    boundary = "rayd-" + uuid.uuid4().hex
    out = []
    for name, filename, data in parts:
        if isinstance(data, str):
            data = data.encode("utf-8")
        disp = 'form-data; name="%s"' % name
        if filename is not None:
            disp += '; filename="%s"' % filename.replace('"', "%22")
        head = "--%s\r\nContent-Disposition: %s\r\n" % (boundary, disp)
        if filename is not None:
            head += "Content-Type: application/octet-stream\r\n"
        out.append(head.encode("utf-8") + b"\r\n" + data + b"\r\n")
    out.append(("--%s--\r\n" % boundary).encode())
    return b"".join(out), "multipart/form-data; boundary=" + boundary


def _scene_type(scene):
    text = scene.decode("utf-8", "replace") if isinstance(scene, bytes) else scene
    return "application/json" if text.lstrip().startswith("{") else "text/x-rayd-cfg"


class Client:
    """base_url: the daemon (http://HOST:PORT); token: an instructor's token,
    sent only to the operations that need it; timeout: seconds per request."""

    def __init__(self, base_url="http://127.0.0.1:8080", token=None, timeout=120):
        self.base_url, self.token, self.timeout = base_url.rstrip("/"), token, timeout

    # ---- the one way a request is made --------------------------------
    def _call(self, operation_id, path_params=None, query=None, body=None, content_type=None, headers=None):
        """(status, headers, body) of a 2xx answer to the operation; raises
        RaydError otherwise, ValueError for a parameter the operation does
        not take."""
        op = OPERATIONS[operation_id]
        path = op.path
        for k, v in (path_params or {}).items():
            path = path.replace("{%s}" % k, urllib.parse.quote(str(v), safe=""))
        if "{" in path:
            raise ValueError("%s: a path parameter is missing: %s" % (operation_id, path))
        q = []
        for k, v in (query or {}).items():
            if v is None:
                continue
            if k not in op.query:
                raise ValueError("%s takes no query parameter %r (it takes %s)" % (operation_id, k, op.query))
            if isinstance(v, bool):
                v = "1" if v else "0"
            q.append((k, str(v)))
        url = self.base_url + path + ("?" + urllib.parse.urlencode(q) if q else "")
        h = dict(headers or {})
        if content_type:
            h["Content-Type"] = content_type
        if op.token and self.token:
            h["Authorization"] = "Bearer " + self.token
        if isinstance(body, str):
            body = body.encode("utf-8")
        if body is None and op.method in ("POST", "PUT"):
            body = b""
        req = urllib.request.Request(url, data=body, headers=h, method=op.method)
        try:
            with urllib.request.urlopen(req, timeout=self.timeout) as resp:
                return resp.status, resp.headers, resp.read()
        except urllib.error.HTTPError as e:
            data = e.read()
            raise RaydError(e.code, data, e.headers) from None

    def _json(self, *args, **kw):
        return json.loads(self._call(*args, **kw)[2].decode("utf-8"))

    # ---- renders and jobs ---------------------------------------------
    def render(self, scene, content_type=None, exr=False, **overrides):
        """POST /v1/render: the scene (cfg or JSON text) rendered now, with
        the query overrides (width, height, samples, ...). exr=True asks for
        the linear OpenEXR instead of the PNG."""
        _, headers, data = self._call("render", query=overrides, body=scene,
                                      content_type=content_type or _scene_type(scene),
                                      headers={"Accept": "image/x-exr"} if exr else None)
        return Render(data, headers)

    def submit(self, scene, content_type=None, hdr=None, **overrides):
        """POST /v1/jobs: a stored job (202 once committed); its Job, queued."""
        query = dict(overrides, hdr=hdr)
        return Job(self._json("submitJob", query=query, body=scene, content_type=content_type or _scene_type(scene)))

    def job(self, job_id):
        """GET /v1/jobs/{id}: the job's state."""
        return Job(self._json("getJob", {"id": job_id}))

    def wait(self, job_id, timeout=300, interval=0.05):
        """Polls GET /v1/jobs/{id} until the job is done, failed or cancelled;
        its last Job. TimeoutError past timeout seconds."""
        end = time.monotonic() + timeout
        while True:
            j = self.job(job_id)
            if j.status in ("done", "failed", "cancelled"):
                return j
            if time.monotonic() > end:
                raise TimeoutError("job %s is still %s after %s s" % (job_id, j.status, timeout))
            time.sleep(interval)
            interval = min(interval * 1.5, 1.0)

    def image(self, job_id, partial=None, exr=False):
        """GET /v1/jobs/{id}/image: the PNG (the tiles so far with partial=True),
        or the EXR of a job submitted with hdr=True."""
        return self._call("getJobImage", {"id": job_id}, query={"partial": partial},
                          headers={"Accept": "image/x-exr"} if exr else None)[2]

    def cancel(self, job_id):
        """DELETE /v1/jobs/{id}: stops a queued or running job; its Job."""
        return Job(self._json("cancelJob", {"id": job_id}))

    # ---- grading --------------------------------------------------------
    def grade(self, image, assignment=None, scene=None, student=None):
        """POST /v1/grade: a PNG graded against an assignment's reference (or
        a scene's rendering); the Verdict, pass or fail."""
        if (assignment is None) == (scene is None):
            raise ValueError("grade: give an assignment or a scene, one of the two")
        parts = [("assignment", None, assignment) if assignment is not None else ("scene", None, scene)]
        if student is not None:
            parts.append(("student", None, student))
        parts.append(("image", "image.png", image))
        body, ct = _multipart(parts)
        return Verdict(self._json("grade", body=body, content_type=ct))

    def grade_record(self, grade_id):
        """GET /v1/grades/{id}: a verdict as it was answered (no token needed)."""
        return Verdict(self._json("getGrade", {"id": grade_id}))

    def grade_file(self, grade_id, name="diff.png"):
        """GET /v1/grades/{id}/{file}: diff.png, reference.png or image.png."""
        return self._call("getGradeImage", {"id": grade_id, "file": name})[2]

    def grade_code(self, source, assignment, filename="PhongMaterial.h", student=None):
        """POST /v1/grade/code: a student's calcReflectedLight (a header, .cpp
        or .c), compiled and run in the daemon's sandbox; the CodeGrade. A
        compile error is RaydError 422 compile_error (its body is a CodeGrade
        too: CodeGrade(json.loads(e.body)))."""
        parts = [("assignment", None, assignment)]
        if student is not None:
            parts.append(("student", None, student))
        parts.append(("source", filename, source))
        body, ct = _multipart(parts)
        return CodeGrade(self._json("gradeCode", body=body, content_type=ct))

    def skeleton(self, material):
        """GET /v1/grade/code/skeleton/{material}: the header a student fills in."""
        return self._call("getCodeSkeleton", {"material": material})[2].decode("utf-8")

    def lobe(self, grade_id):
        """GET /v1/grade/code/{id}/lobe.svg: a code grade's lobe plots."""
        return self._call("getCodeLobe", {"id": grade_id})[2].decode("utf-8")

    # ---- a class (the instructor's token) -------------------------------
    def grade_batch(self, assignment, images=None, archive=None):
        """POST /v1/grade/batch: images ({student: PNG bytes}) or archive
        ((file name, bytes) of a .zip or .tar.gz of PNGs); the Batch, running."""
        if (images is None) == (archive is None):
            raise ValueError("grade_batch: give images or an archive, one of the two")
        parts = [("assignment", None, assignment)]
        if archive is not None:
            parts.append(("archive", archive[0], archive[1]))
        else:
            for student, png in images.items():
                parts.append(("student", None, student))
                parts.append(("image", "%s.png" % student, png))
        body, ct = _multipart(parts)
        return Batch(self._json("gradeBatch", body=body, content_type=ct))

    def regrade(self, assignment):
        """POST /v1/grade/regrade: the assignment's image records graded again; the Batch, running."""
        return Batch(self._json("regradeAssignment", query={"assignment": assignment}))

    def batch(self, batch_id):
        """GET /v1/grade/batch/{id}: its status and the rows so far."""
        return Batch(self._json("getGradeBatch", {"id": batch_id}))

    def wait_batch(self, batch_id, timeout=600, interval=0.05):
        """Polls the batch until it is no longer running; its last Batch."""
        end = time.monotonic() + timeout
        while True:
            b = self.batch(batch_id)
            if b.status != "running":
                return b
            if time.monotonic() > end:
                raise TimeoutError("batch %s is still running after %s s" % (batch_id, timeout))
            time.sleep(interval)
            interval = min(interval * 1.5, 1.0)

    def batch_table(self, batch_id, form="csv"):
        """GET /v1/grade/batch/{id}/results.csv (str) or results.json ([GradeRow])."""
        data = self._call("getGradeBatchTable", {"id": batch_id, "table": "results." + form})[2]
        if form == "json":
            return [GradeRow(r) for r in json.loads(data.decode("utf-8"))]
        return data.decode("utf-8")

    def grades(self, assignment=None, student=None, since=None):
        """GET /v1/grades: the grade records, oldest first ([GradeRow])."""
        data = self._json("listGrades", query={"assignment": assignment, "student": student, "since": since})
        return [GradeRow(r) for r in data.get("grades", [])]

    def grades_csv(self, assignment=None, student=None, since=None, excel=False):
        """GET /v1/grades with Accept: text/csv: the records as CSV (excel: with the byte order mark first)."""
        query = {"assignment": assignment, "student": student, "since": since, "excel": "1" if excel else None}
        return self._call("listGrades", query=query, headers={"Accept": "text/csv"})[2].decode("utf-8")

    def gradebook(self, format, excel=False):
        """GET /v1/gradebook?format=moodle|canvas: the scores that count, as the LMS's import reads them."""
        query = {"format": format, "excel": "1" if excel else None}
        return self._call("getGradebook", query=query)[2].decode("utf-8")

    def batches(self, assignment=None, until=None, limit=None):
        """GET /v1/grade/batch: the batches, newest first ([BatchSummary]);
        the next page from until=the last one's created_at."""
        data = self._json("listGradeBatches", query={"assignment": assignment, "until": until, "limit": limit})
        return [BatchSummary(b) for b in data.get("batches", [])]

    def delete_batch(self, batch_id):
        """DELETE /v1/grade/batch/{id}: a running batch cancelled (its Batch,
        cancelled); one that had ended deleted with its records (None)."""
        status, _, data = self._call("deleteGradeBatch", {"id": batch_id})
        return Batch(json.loads(data.decode("utf-8"))) if status == 200 else None

    def delete_student(self, student):
        """DELETE /v1/grades?student=: the student's records, with their
        images; how many went."""
        return self._json("deleteStudentGrades", query={"student": student})["deleted"]

    def delete_grade(self, grade_id):
        """DELETE /v1/grades/{id}: one record, with its images."""
        self._call("deleteGrade", {"id": grade_id})

    # ---- what the daemon offers -----------------------------------------
    def assignments(self):
        """GET /v1/assignments: {"assignments": [...]}."""
        return self._json("listAssignments")

    def assignment_scene(self, name):
        """GET /v1/assignments/{name}/scene: the assignment's scene text."""
        return self._call("getAssignmentSceneFile", {"name": name})[2].decode("utf-8")

    def scenes(self):
        """GET /v1/scenes: {"scenes": [...]}."""
        return self._json("listScenes")

    def scene(self, name):
        """GET /v1/scenes/{name}: a bundled scene's text."""
        return self._call("getScene", {"name": name})[2].decode("utf-8")

    def health(self):
        """GET /healthz."""
        return self._json("health")

    def ready(self):
        """GET /readyz: {"status": "ready", ...}; RaydError 503 while not ready."""
        return self._json("ready")
