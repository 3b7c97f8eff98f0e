// Browser test of the verdict page: GET /v1/grades/{id} opened in Chromium
// answers the page at / in its one-grade mode, which reads the verdict's
// JSON from the same address. An image grade that passes, one just over
// the threshold (its digits), one whose image and reference the server no
// longer has (after a restart), a batch's error row, no such grade, and code
// grades (a pass, a NaN) when the sandbox starts here. The number
// formatting and the record line are also checked as functions of the page.
// Screenshots: build/browser-screenshots/verdict/.
import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import { execFileSync } from "node:child_process";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { ROOT, RAYD, startDaemon, stopDaemon, logTail, launchChromium } from "./daemon.mjs";
import { decodePng, encodePng } from "./png.mjs";

const SHOTS = path.join(ROOT, "build", "browser-screenshots", "verdict");
const STEP_MS = 20_000;
const GRADE_MS = 90_000;
const STUDENTS = path.join(ROOT, "tests", "codegrade", "students");
const TOKEN = "verdict-page-test-token-0123456789";

let tmp, dir, d, browser, sandboxOk = false;
const png = {}; // pass, over, fail: the students' images (bytes)
const grades = {}; // name -> verdict JSON as POST answered it

function flags() {
  return ["--instructor-tokens", path.join(tmp, "tokens")];
}

async function post(route, fields) {
  const form = new FormData();
  for (const [k, v] of Object.entries(fields)) {
    if (Array.isArray(v)) form.append(k, new Blob([v[1]]), v[0]);
    else form.append(k, v);
  }
  const resp = await fetch(d.base + route, { method: "POST", body: form });
  const body = await resp.json();
  assert.ok(resp.status < 300, `${route}: ${resp.status} ${JSON.stringify(body)}`);
  return body;
}

// The phong reference with 80 pixels 10 levels off: 80 of 76800 is
// 0.104%, just over the 0.10% the assignment allows.
function justOver(ref) {
  const img = decodePng(ref);
  for (let i = 0; i < 80; i++) {
    const o = ((i * 971) % (img.width * img.height)) * img.channels;
    img.data[o] = img.data[o] > 128 ? img.data[o] - 10 : img.data[o] + 10;
  }
  return encodePng(img);
}

before(async () => {
  fs.mkdirSync(SHOTS, { recursive: true });
  for (const f of fs.readdirSync(SHOTS)) fs.rmSync(path.join(SHOTS, f));
  tmp = fs.mkdtempSync(path.join(os.tmpdir(), "rayd-verdict-page-"));
  dir = path.join(tmp, "d");
  fs.writeFileSync(path.join(tmp, "tokens"), TOKEN + "\n", { mode: 0o600 });
  for (const [name, scene] of [["pass", "phong"], ["fail", "diffuse"]]) {
    const out = path.join(tmp, name + ".png");
    execFileSync(RAYD, ["render", `scenes/assignments/${scene}.cfg`, "-o", out], { cwd: ROOT, stdio: "ignore" });
    png[name] = fs.readFileSync(out);
  }
  png.over = justOver(png.pass);
  d = await startDaemon(dir, flags());
  sandboxOk = !/code grading is off/.test(fs.readFileSync(d.log, "utf8"));
  grades.pass = await post("/v1/grade", { assignment: "phong", student: "alice", image: ["alice.png", png.pass] });
  grades.over = await post("/v1/grade", { assignment: "phong", student: "bob", image: ["bob.png", png.over] });
  grades.fail = await post("/v1/grade", { assignment: "phong", student: "carol", image: ["carol.png", png.fail] });
  browser = await launchChromium();
});

after(async () => {
  if (browser) await browser.close();
  await stopDaemon(d);
  if (tmp) fs.rmSync(tmp, { recursive: true, force: true });
});

async function open(url) {
  const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
  page.errors = [];
  page.on("pageerror", (e) => page.errors.push(String(e)));
  const resp = await page.goto(d.base + url);
  return { page, resp };
}

async function metrics(page) {
  return Object.fromEntries(await page.$$eval("#metrics tr", (rows) =>
    rows.map((r) => [r.cells[0].textContent, r.cells[1].textContent])));
}

async function imagesLoaded(page, ids) {
  await page.waitForFunction((list) => list.every((id) => {
    const i = document.getElementById(id);
    return i.complete && i.naturalWidth > 0;
  }), ids, { timeout: STEP_MS });
}

test("an image grade that passes: the page, not JSON, at the student's link", { timeout: 60_000 }, async () => {
  const { page, resp } = await open("/v1/grades/" + grades.pass.id);
  assert.equal(resp.status(), 200);
  assert.match(resp.headers()["content-type"], /^text\/html/);
  assert.match(resp.headers()["vary"], /Accept/);
  await page.waitForSelector("#verdict:not([hidden])", { timeout: STEP_MS });
  assert.equal(await page.textContent("#verdict"), "PASS");
  assert.match(await page.textContent("#one-title"), /^alice — Phong: .* \(image\)$/);
  assert.match((await metrics(page))["Failed pixels"], /^0 \(0\.000%, limit 0\.10%\)$/);
  for (const hidden of ["#scene-panel", "#class-panel", "#code-panel", "#grade-btn", "#assignment-pick"]) {
    assert.equal(await page.isVisible(hidden), false, hidden + " is not on a grade's page");
  }
  await imagesLoaded(page, ["diff-img", "ref-img", "mine-img"]);
  assert.equal(await page.isVisible("#tab-slider"), true);
  await page.click("#tab-slider");
  assert.equal(await page.isVisible("#view-slider"), true);
  await page.screenshot({ path: path.join(SHOTS, "1-image-pass.png"), fullPage: true });
  assert.deepEqual(page.errors, []);
  await page.close();
});

test("just over the threshold: the digits show that 0.104% is over 0.10%", { timeout: 60_000 }, async () => {
  assert.equal(grades.over.pass, false);
  assert.equal(grades.over.metrics.failed_pixels, 80);
  const { page } = await open("/v1/grades/" + grades.over.id);
  await page.waitForSelector("#verdict:not([hidden])", { timeout: STEP_MS });
  assert.equal(await page.textContent("#verdict"), "FAIL");
  assert.equal((await metrics(page))["Failed pixels"], "80 (0.104%, limit 0.10%)");
  await imagesLoaded(page, ["diff-img"]);
  await page.screenshot({ path: path.join(SHOTS, "2-image-just-over.png"), fullPage: true });
  // A student opens the link on a phone: nothing scrolls sideways.
  await page.setViewportSize({ width: 375, height: 740 });
  assert.equal(await page.evaluate(() => document.documentElement.scrollWidth <= window.innerWidth), true);
  await page.screenshot({ path: path.join(SHOTS, "2c-phone.png"), fullPage: true });
  assert.deepEqual(page.errors, []);
  await page.close();
});

test("the page's numbers: percentages on their side of the limit, NaN said, the record", { timeout: 60_000 }, async () => {
  const { page } = await open("/v1/grades/" + grades.pass.id);
  await page.waitForSelector("#verdict:not([hidden])", { timeout: STEP_MS });
  const wrong = await page.evaluate(() => {
    const bad = [];
    // Every count of failed pixels of a 320x240 image near a 0.1% limit,
    // and of a few other sizes and limits.
    for (const [n, limit] of [[76800, 0.001], [76800, 0.0005], [1000, 0.01], [3, 0.5], [7, 1 / 3]]) {
      const lim = Number(limitPercent(limit).slice(0, -1));
      for (let k = 0; k <= Math.min(n, 200); k++) {
        const x = k / n, shown = percentOff(x, limit), v = Number(shown.slice(0, -1));
        if (x > limit ? !(v > lim) : !(v <= lim)) bad.push(`${k}/${n} against ${limit}: ${shown} beside ${limitPercent(limit)}`);
        if (k > 0 && v === 0) bad.push(`${k}/${n} reads 0: ${shown}`);
      }
    }
    return bad;
  });
  assert.deepEqual(wrong, []);
  const said = await page.evaluate(() => ({
    over: percentOff(80 / 76800, 0.001),
    limit: limitPercent(0.001),
    nan: percentOff(null, 0.001),
    fmtNull: fmt(null, 3),
    got: returned([null, null, null]),
    gotOne: returned([0.5, null, 0.25]),
    record: recordText({ student: "dave", assignment: "phong", kind: "image", submitted_at: "2026-12-08T10:00:00Z",
      late: true, late_days: 2, counts: true, score: 7.5, points: 10, due_at: "2026-12-06T10:00:00Z" }),
    onTime: recordText({ submitted_at: "2026-12-01T09:30:00.123Z", late: false, late_days: 0, counts: false,
      score: null, points: 10, due_at: null }),
    none: recordText(undefined),
  }));
  assert.equal(said.over, "0.104%");
  assert.equal(said.limit, "0.10%");
  assert.equal(said.nan, "not a number (NaN)");
  assert.equal(said.fmtNull, "not a number (NaN)");
  assert.match(said.got, /^\(NaN, NaN, NaN\): not a number \(NaN\) in every channel, made by exactly these inputs/);
  assert.match(said.gotOne, /^\(0\.5000, NaN, 0\.2500\): not a number \(NaN\) in green,/);
  assert.equal(said.record, "submitted 2026-12-08 10:00 UTC, 2 days late (due 2026-12-06 10:00 UTC); counts; 7.5 of 10 points");
  assert.equal(said.onTime, "submitted 2026-12-01 09:30 UTC; does not count; not scored yet of 10 points");
  assert.equal(said.none, "");
  assert.deepEqual(page.errors, []);
  await page.close();
});

// The record object another part of the server adds to a verdict: shown
// when present (the page works without it, as above). The verdict is the
// real one, with a record put in as the page fetches it.
test("a verdict with its record: submitted, late, counts, points", { timeout: 60_000 }, async () => {
  const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
  const errors = [];
  page.on("pageerror", (e) => errors.push(String(e)));
  const url = d.base + "/v1/grades/" + grades.over.id;
  await page.route(url, async (route) => {
    if (!/json/.test(route.request().headers()["accept"] || "")) return route.continue();
    const resp = await route.fetch();
    const v = await resp.json();
    v.record = { student: "<b>bob</b>", assignment: "phong", kind: "image", submitted_at: "2026-12-08T10:00:00Z",
      late: true, late_days: 2, counts: true, score: 7.5, points: 10, due_at: "2026-12-06T10:00:00Z" };
    return route.fulfill({ response: resp, json: v });
  });
  await page.goto(url);
  await page.waitForSelector("#verdict:not([hidden])", { timeout: STEP_MS });
  assert.equal(await page.textContent("#one-title"), "<b>bob</b> — Phong: three spheres of rising shininess (image)");
  assert.equal(await page.textContent("#one-record"),
    "submitted 2026-12-08 10:00 UTC, 2 days late (due 2026-12-06 10:00 UTC); counts; 7.5 of 10 points");
  await imagesLoaded(page, ["diff-img"]);
  await page.screenshot({ path: path.join(SHOTS, "2b-with-record.png"), fullPage: true });
  assert.deepEqual(errors, []);
  await page.close();
});

test("no such grade: 404, and the page says so", { timeout: 60_000 }, async () => {
  const { page, resp } = await open("/v1/grades/g" + "0".repeat(32));
  assert.equal(resp.status(), 404);
  assert.match(resp.headers()["content-type"], /^text\/html/);
  await page.waitForSelector("#one-msg.error", { timeout: STEP_MS });
  assert.match(await page.textContent("#one-msg"), /no such grade/);
  assert.equal(await page.isVisible("#grade-panel"), false);
  await page.screenshot({ path: path.join(SHOTS, "3-no-such-grade.png"), fullPage: true });
  assert.deepEqual(page.errors, []);
  await page.close();
});

test("a batch's error row: not graded, with the server's words", { timeout: 90_000 }, async () => {
  const form = new FormData();
  form.append("assignment", "phong");
  form.append("image", new Blob(["[render]\nwidth = 4\n"]), "erin.png");
  const auth = { Authorization: "Bearer " + TOKEN };
  let b = await (await fetch(d.base + "/v1/grade/batch", { method: "POST", headers: auth, body: form })).json();
  for (let n = 0; b.status === "running" && n < 200; n++) {
    await new Promise((r) => setTimeout(r, 100));
    b = await (await fetch(d.base + "/v1/grade/batch/" + b.id, { headers: auth })).json();
  }
  const row = b.results.find((r) => r.student === "erin");
  assert.ok(row && row.error && row.grade_id, JSON.stringify(b));
  const { page } = await open("/v1/grades/" + row.grade_id);
  await page.waitForSelector("#one-msg.error", { timeout: STEP_MS });
  assert.equal(await page.textContent("#one-msg"), "Not graded: the image is not a PNG file.");
  assert.match(await page.textContent("#one-title"), /^erin — phong \(image\)$/);
  await page.screenshot({ path: path.join(SHOTS, "4-error-row.png"), fullPage: true });
  assert.deepEqual(page.errors, []);
  await page.close();
});

test("code grades: a pass with its lobe plot, and NaN said as such with its inputs", { timeout: 3 * GRADE_MS }, async (t) => {
  if (!sandboxOk) {
    t.skip("this machine's sandbox cannot start: " + logTail(d.log, 3));
    return;
  }
  const source = (name) => ["PhongMaterial.h", fs.readFileSync(path.join(STUDENTS, name))];
  grades.codeOk = await post("/v1/grade/code", { assignment: "phong", student: "frank", source: source("phong_ok.h") });
  grades.codeNan = await post("/v1/grade/code", { assignment: "phong", student: "grace", source: source("phong_nan.h") });

  let { page } = await open("/v1/grades/" + grades.codeOk.id);
  await page.waitForSelector("#code-verdict:not([hidden])", { timeout: STEP_MS });
  assert.match(await page.textContent("#code-verdict"), /^PASS/);
  assert.match(await page.textContent("#one-title"), /^frank — Phong: .* \(code\)$/);
  await imagesLoaded(page, ["code-diff", "code-lobe"]);
  assert.match(await page.textContent("#code-image-verdict"), /^The image passes: 0\.000% of pixels off \(at most 0\.10%\)/);
  assert.equal(await page.isVisible("#grade-panel"), false);
  assert.equal(await page.isVisible("#code-file"), false);
  await page.screenshot({ path: path.join(SHOTS, "5-code-pass.png"), fullPage: true });
  assert.deepEqual(page.errors, []);
  await page.close();

  ({ page } = await open("/v1/grades/" + grades.codeNan.id));
  await page.waitForSelector("#code-verdict:not([hidden])", { timeout: STEP_MS });
  assert.match(await page.textContent("#code-verdict"), /^FAIL/);
  const causes = await page.$$eval("#code-cause-list li", (l) => l.map((li) => li.textContent));
  const nan = causes.find((c) => /not_finite/.test(c));
  assert.ok(nan, causes.join("\n"));
  assert.match(nan, /yours \(NaN, NaN, NaN\): not a number \(NaN\) in every channel, made by exactly these inputs/);
  assert.match(nan, /N = \(.*\), incoming = \(.*\), outgoing = \(.*\), kd = \(.*\), ks = \(.*\), shininess = \d/);
  assert.doesNotMatch(causes.join("\n"), /0\.000, 0\.000, 0\.000/);
  await page.screenshot({ path: path.join(SHOTS, "6-code-nan.png"), fullPage: true });
  assert.deepEqual(page.errors, []);
  await page.close();
});

// Last: it restarts the daemon, which keeps the records but not the images.
test("after a restart: the heat map stays, the slider and flip go, saying why", { timeout: 90_000 }, async () => {
  await stopDaemon(d);
  d = await startDaemon(dir, flags());
  const { page, resp } = await open("/v1/grades/" + grades.fail.id);
  assert.equal(resp.status(), 200);
  await page.waitForSelector("#verdict:not([hidden])", { timeout: STEP_MS });
  assert.equal(await page.textContent("#verdict"), "FAIL");
  await imagesLoaded(page, ["diff-img"]);
  await page.waitForSelector("#images-gone:not([hidden])", { timeout: STEP_MS });
  assert.equal(await page.isVisible("#tab-slider"), false);
  assert.equal(await page.isVisible("#tab-toggle"), false);
  assert.equal(await page.isVisible("#view-diff"), true);
  await page.screenshot({ path: path.join(SHOTS, "7-image-after-restart.png"), fullPage: true });
  // The image 404s are the page's own requests, not script errors.
  assert.deepEqual(page.errors, []);
  await page.close();
  if (grades.codeOk) {
    const { page: p2 } = await open("/v1/grades/" + grades.codeOk.id);
    await p2.waitForSelector("#code-verdict:not([hidden])", { timeout: STEP_MS });
    await imagesLoaded(p2, ["code-diff"]);
    await p2.waitForSelector("#code-lobe-gone:not([hidden])", { timeout: STEP_MS });
    await p2.waitForSelector("#code-image-more", { state: "hidden", timeout: STEP_MS });
    await p2.screenshot({ path: path.join(SHOTS, "8-code-after-restart.png"), fullPage: true });
    assert.deepEqual(p2.errors, []);
    await p2.close();
  }
});
