"""What the tests of a class's batches share (grade_batch_test.py,
batch_manage_test.py): posting a batch's form with an instructor's headers,
and polling it until it is no longer running."""
import json
import time

from rayd_http import form_parts


def post_batch(d, parts, headers):
    """POST /v1/grade/batch of the form parts (rayd_http.form_parts'),
    with headers (the token); (status, headers, body)."""
    body, ct = form_parts(parts)
    return d.request("POST", "/v1/grade/batch", body=body, headers=dict(headers, **{"Content-Type": ct}))


def wait_batch(d, bid, headers, bound=120):
    """GET /v1/grade/batch/{bid} until it is not running (or bound
    seconds): its last status, {"status": "http N"} for another answer."""
    t0, last = time.time(), {}
    while time.time() - t0 < bound:
        st, _, b = d.request("GET", "/v1/grade/batch/" + bid, headers=headers)
        last = json.loads(b) if st == 200 else {"status": "http %d" % st}
        if last.get("status") != "running":
            break
        time.sleep(0.05)
    return last
