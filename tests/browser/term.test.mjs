// Browser test of a term in the class view (docs/grading.md, "A term" and
// "A roster"): a daemon with --roster grades a batch through the API; the
// page, given the instructor's token and the batch, shows each row's score
// of the assignment's points, flags the file not on the roster, lists the
// roster's student who handed nothing in as MISSING (counted apart from
// the graded), and a regrade's late records say "late". Screenshots go to
// build/browser-screenshots/term/.
//
// Run from the repository root: tests/browser/run.sh (or `node --test tests/browser/`).

import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import { execFile } from "node:child_process";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { ROOT, RAYD, serveHas, startDaemon, stopDaemon, launchChromium } from "./daemon.mjs";
import { encodePng } from "./png.mjs";

const SHOTS = path.join(ROOT, "build", "browser-screenshots", "term");
const TOKEN = "t0k3n-for-the-term";
const SCENE = "[render]\nwidth = 16\nheight = 12\n[light]\ntype = point\nposition = 0 5 5\ncolor = 1 1 1\n" +
  "[material m]\ntype = diffuse\nkd = 0.5 0.5 0.5\n[sphere]\ncenter = 0 0 0\nradius = 1\nmaterial = m\n";
const skip = fs.existsSync(RAYD) && serveHas("--roster") ? false : `${RAYD} serve has no --roster`;

let tmp, daemon, browser, right, wrong;

const auth = { Authorization: "Bearer " + TOKEN };
const utc = (s) => new Date(Date.now() + s * 1000).toISOString().replace(/\.\d+Z$/, "Z");

function render(cfg, out) {
  return new Promise((resolve, reject) => execFile(RAYD, ["render", cfg, "-o", out, "--quiet"], { cwd: ROOT },
    (err) => (err ? reject(err) : resolve(fs.readFileSync(out)))));
}

async function batch(assignment, images) {
  const form = new FormData();
  form.append("assignment", assignment);
  for (const [student, png] of images) form.append("image", new Blob([png], { type: "image/png" }), student + ".png");
  const resp = await fetch(daemon.base + "/v1/grade/batch", { method: "POST", body: form, headers: auth });
  assert.equal(resp.status, 202, await resp.clone().text());
  const { id } = await resp.json();
  for (let k = 0; k < 600; k++) {
    const b = await (await fetch(daemon.base + "/v1/grade/batch/" + id, { headers: auth })).json();
    if (b.status !== "running") return b;
    await new Promise((r) => setTimeout(r, 50));
  }
  throw new Error("the batch did not end");
}

// The class view of batch id, as a reload of the tab that posted it shows it.
async function openBatch(id, name) {
  const context = await browser.newContext({ viewport: { width: 1100, height: 800 } });
  await context.addInitScript(([token, batchId]) => {
    sessionStorage.setItem("rayd.instructor-token", token);
    sessionStorage.setItem("rayd.batch", batchId);
  }, [TOKEN, id]);
  const page = await context.newPage();
  await page.goto(daemon.base + "/");
  await page.waitForFunction(() => document.querySelectorAll("#class-table tbody tr").length > 0);
  const rows = await page.$$eval("#class-table tbody tr", (trs) => trs.map((tr) => ({
    student: tr.dataset.student, verdict: tr.querySelector(".tag").innerText.trim(), score: tr.cells[4].innerText.trim(),
    notes: [...tr.querySelectorAll(".note-tag")].map((t) => t.innerText.trim()),
  })));
  const summary = await page.locator("#class-summary").innerText();
  await page.locator("#class-results").scrollIntoViewIfNeeded();
  await page.screenshot({ path: path.join(SHOTS, name + ".png"), fullPage: true });
  await context.close();
  return { rows, summary };
}

before(async () => {
  if (skip) return;
  tmp = fs.mkdtempSync(path.join(os.tmpdir(), "rayd-term-page-"));
  fs.mkdirSync(SHOTS, { recursive: true });
  const dir = path.join(tmp, "assignments");
  fs.mkdirSync(dir);
  fs.writeFileSync(path.join(dir, "tiny.cfg"), SCENE);
  fs.writeFileSync(path.join(dir, "tiny.grade"), "points = 4\ncredit = partial\nimage_credit = 1:0.25\n");
  fs.writeFileSync(path.join(dir, "late.cfg"), SCENE);
  fs.writeFileSync(path.join(dir, "late.grade"), `points = 4\ndue = ${utc(-30 * 3600)}\nlate_days = 3\nlate_penalty = 0.25\n`);
  fs.writeFileSync(path.join(tmp, "roster.csv"), "student,name\nann,Ann\nbob,Bob\ncat,Cat\n");
  fs.writeFileSync(path.join(tmp, "tokens"), TOKEN + "\n");
  right = await render(path.join(dir, "tiny.cfg"), path.join(tmp, "right.png"));
  wrong = encodePng({ width: 16, height: 12, channels: 3, data: new Uint8Array(16 * 12 * 3).fill(255) });
  daemon = await startDaemon(path.join(tmp, "d"), ["--assignments", dir, "--instructor-tokens", path.join(tmp, "tokens"),
    "--roster", path.join(tmp, "roster.csv"), "--threads", "2"]);
  browser = await launchChromium();
});

after(async () => {
  await browser?.close();
  await stopDaemon(daemon);
  if (tmp) fs.rmSync(tmp, { recursive: true, force: true });
});

test("a batch with a roster: scores, a file not on the roster, a student without a submission", { skip, timeout: 120_000 }, async () => {
  const b = await batch("tiny", [["ann", right], ["bob", wrong], ["zed", right]]);
  const { rows, summary } = await openBatch(b.id, "1-roster");
  const by = Object.fromEntries(rows.map((r) => [r.student, r]));
  assert.deepEqual(Object.keys(by).sort(), ["ann", "bob", "cat", "zed"], JSON.stringify(rows));
  assert.equal(by.ann.verdict, "PASS");
  assert.equal(by.ann.score, "4.00 / 4.00");
  assert.equal(by.bob.score, "1.00 / 4.00", "partial credit: every pixel off is within 1, a quarter of 4");
  assert.equal(by.cat.verdict, "MISSING");
  assert.deepEqual(by.zed.notes, ["not on the roster"]);
  assert.deepEqual(by.ann.notes, [], "ann is on the roster, and a batch is on time");
  assert.match(summary, /^tiny: 3 of 3 graded — 2 pass, 1 fail, 0 could not be graded, 1 on the roster without a submission\.$/, summary);
});

test("a regrade of late work keeps its lateness and penalty", { skip, timeout: 120_000 }, async () => {
  for (const student of ["ann", "bob"]) {
    const form = new FormData();
    form.append("assignment", "late");
    form.append("student", student);
    form.append("image", new Blob([right], { type: "image/png" }), "i.png");
    assert.equal((await fetch(daemon.base + "/v1/grade", { method: "POST", body: form })).status, 200);
  }
  const resp = await fetch(daemon.base + "/v1/grade/regrade?assignment=late", { method: "POST", headers: auth });
  assert.equal(resp.status, 202);
  const { id } = await resp.json();
  for (let k = 0; k < 600; k++) {
    const b = await (await fetch(daemon.base + "/v1/grade/batch/" + id, { headers: auth })).json();
    if (b.status !== "running") break;
    await new Promise((r) => setTimeout(r, 50));
  }
  const { rows } = await openBatch(id, "2-regrade-late");
  const graded = rows.filter((r) => r.verdict !== "MISSING");
  assert.equal(graded.length, 2, JSON.stringify(rows));
  for (const r of graded) {
    assert.equal(r.verdict, "PASS");
    assert.deepEqual(r.notes, ["late"]);
    assert.equal(r.score, "2.00 / 4.00", "two started days late at a quarter a day");
  }
});
