// Browser test of the page's class view: an instructor grades a whole class
// (POST /v1/grade/batch) from a folder or an archive, watches it progress,
// sorts the table, downloads the CSV and opens one student's verdict.
//
// Starts its own daemons: one with --instructor-tokens (a temporary file)
// and --data-dir in the temporary folder, one with a low --max-batch-images
// (413) and one without --instructor-tokens (404). The twelve students'
// images are made here: rayd render of the assignment's scene as the API
// serves it, at the assignment's size, and each typical mistake. Screenshots
// go to build/browser-screenshots/class/.
//
// Run from the repository root: tests/browser/run.sh (or `node --test tests/browser/`).

import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import { execFile } from "node:child_process";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { ROOT, RAYD, CHROMIUM, serveHas, startDaemon, stopDaemon, logTail, launchChromium } from "./daemon.mjs";
import { decodePng, encodePng, withAlpha } from "./png.mjs";

const SHOTS = path.join(ROOT, "build", "browser-screenshots", "class");
const RENDER_MS = 60_000;
const STEP_MS = 20_000;
const TEST_MS = 240_000;
const TOKEN = "t0k3n-for-the-course";
const ASSIGNMENT = "phong";

// A rayd without the class routes cannot run any of this.
const SUPPORTED = fs.existsSync(RAYD) && serveHas("--instructor-tokens");
const skip = SUPPORTED ? false : `${RAYD} serve has no --instructor-tokens (build a rayd with class grading)`;

let tmp, daemon, browser;
const dirs = {}; // class folder, archives
let spec; // the assignment as GET /v1/assignments gives it

// What every student's image should get: pass, fail, or error (not graded),
// and for errors what the message must say.
const EXPECTED = {
  alice: { verdict: "PASS", why: "rayd render of the scene" },
  bob: { verdict: "PASS", why: "the same pixels, written with one thread and zlib level 9" },
  carol: { verdict: "PASS", why: "the same pixels as RGBA" },
  peggy: { verdict: "PASS", why: "every channel one level brighter (within the threshold)" },
  frank: { verdict: "FAIL", why: "ambient forgotten" },
  grace: { verdict: "FAIL", why: "shininess halved" },
  heidi: { verdict: "FAIL", why: "a black image" },
  ivan: { verdict: "FAIL", why: "the diffuse assignment's image" },
  judy: { verdict: "FAIL", why: "the key light on the wrong side" },
  dave: { verdict: "ERROR", why: "half the size", message: /160x120/ },
  erin: { verdict: "ERROR", why: "a scene file named .png", message: /PNG/i },
  oscar: { verdict: "ERROR", why: "a PNG cut off halfway", message: /PNG|damaged|truncated|corrupt/i },
};
const STUDENTS = Object.keys(EXPECTED).sort();

function run(cmd, args) {
  return new Promise((resolve, reject) => {
    execFile(cmd, args, { cwd: ROOT, timeout: RENDER_MS }, (err, stdout, stderr) => {
      if (err) reject(new Error(`${cmd} ${args.join(" ")} failed: ${err.message}\n${stderr}`));
      else resolve({ stdout, stderr });
    });
  });
}

async function api(p, init = {}) {
  const resp = await fetch(daemon.base + p, init);
  return resp;
}
const bearer = (t = TOKEN) => ({ Authorization: "Bearer " + t });

// The twelve students' images, made from the scene the server grades against.
async function makeClass(dir) {
  fs.mkdirSync(dir, { recursive: true });
  const W = spec.width, H = spec.height;
  const scene = await (await api(`/v1/assignments/${ASSIGNMENT}/scene`)).text();
  assert.match(scene, /\[render\]/, "the assignment's scene is served");
  const variant = async (name, text, extra = []) => {
    const cfg = path.join(tmp, name + ".cfg");
    fs.writeFileSync(cfg, text);
    const out = path.join(dir, name + ".png");
    await run(RAYD, ["render", cfg, "-o", out, "--width", String(W), "--height", String(H), "--quiet", ...extra]);
    return out;
  };
  const alice = await variant("alice", scene);
  await variant("bob", scene, ["--threads", "1", "--png-level", "9"]);
  const px = decodePng(fs.readFileSync(alice));
  assert.deepEqual([px.width, px.height, px.channels], [W, H, 3]);
  fs.writeFileSync(path.join(dir, "carol.png"), encodePng(withAlpha(px)));
  const brighter = new Uint8Array(px.data.length);
  for (let i = 0; i < px.data.length; i++) brighter[i] = Math.min(255, px.data[i] + 1);
  fs.writeFileSync(path.join(dir, "peggy.png"), encodePng({ ...px, data: brighter }));

  const noAmbient = scene.replace(/^(\s*ambient\s*=).*$/gm, "$1 0 0 0");
  assert.notEqual(noAmbient, scene, "the scene has ambient terms to forget");
  await variant("frank", noAmbient);
  const halfShiny = scene.replace(/^(\s*shininess\s*=\s*)([\d.]+)/gm, (_, k, v) => k + Number(v) / 2);
  assert.notEqual(halfShiny, scene, "the scene has shininess to halve");
  await variant("grace", halfShiny);
  fs.writeFileSync(path.join(dir, "heidi.png"), encodePng({ width: W, height: H, channels: 3, data: new Uint8Array(W * H * 3) }));
  const diffuse = await (await api("/v1/assignments/diffuse/scene")).text();
  await variant("ivan", diffuse);
  const moved = scene.replace(/(\[light key\][^[]*position\s*=\s*)(-?[\d.]+)/, (_, k, x) => k + String(-Number(x)));
  assert.notEqual(moved, scene, "the scene has a key light to move");
  await variant("judy", moved);

  await run(RAYD, ["render", path.join(tmp, "alice.cfg"), "-o", path.join(dir, "dave.png"), "--width", String(W / 2), "--height", String(H / 2), "--quiet"]);
  fs.writeFileSync(path.join(dir, "erin.png"), scene);
  const whole = fs.readFileSync(alice);
  fs.writeFileSync(path.join(dir, "oscar.png"), whole.subarray(0, whole.length >> 1));
  // A file a desktop leaves in folders: not a student, the page skips it.
  fs.writeFileSync(path.join(dir, ".DS_Store"), Buffer.from([0, 0, 0, 1, 0x42, 0x75, 0x64, 0x31]));
}

before(async () => {
  if (!SUPPORTED) return;
  assert.ok(fs.existsSync(CHROMIUM), `no Chromium at ${CHROMIUM}: apt-get install -y chromium`);
  tmp = fs.mkdtempSync(path.join(os.tmpdir(), "rayd-class-"));
  fs.mkdirSync(SHOTS, { recursive: true });
  for (const f of fs.readdirSync(SHOTS)) if (/\.(png|log|csv|json)$/.test(f)) fs.rmSync(path.join(SHOTS, f));

  const tokens = path.join(tmp, "tokens");
  fs.writeFileSync(tokens, "# the course's instructors\n\n" + TOKEN + "\n# a second one\nanother-instructor\n");
  const assignments = path.join(tmp, "assignments");
  fs.cpSync(path.join(ROOT, "scenes/assignments"), assignments, { recursive: true });
  fs.copyFileSync(path.join(ROOT, "scenes/assignments/phong.cfg"), path.join(assignments, "zz_broken.cfg"));
  fs.writeFileSync(path.join(assignments, "zz_broken.grade"), "fail = banana\n");
  dirs.assignments = assignments;
  dirs.tokens = tokens;
  daemon = await startDaemon(path.join(tmp, "daemon"), ["--scenes", "scenes", "--assignments", assignments, "--instructor-tokens", tokens]);

  const list = (await (await api("/v1/assignments")).json()).assignments;
  spec = list.find((a) => a.name === ASSIGNMENT);
  assert.ok(spec && !spec.error, `assignment ${ASSIGNMENT} loads`);
  dirs.class = path.join(tmp, "class");
  await makeClass(dirs.class);
  // The same images as an archive, in a folder of its own as students' zips often are.
  dirs.archive = path.join(tmp, "class.tar.gz");
  await run("tar", ["-czf", dirs.archive, "-C", tmp, "--exclude", ".DS_Store", "class"]);

  browser = await launchChromium();
}, { timeout: 300_000 });

after(async () => {
  try {
    if (browser) await browser.close();
  } finally {
    const res = await stopDaemon(daemon);
    if (res && (res.code !== 0 || res.killed)) console.log(`# rayd serve did not stop cleanly: ${JSON.stringify(res)}\n${logTail(daemon.log)}`);
    if (daemon && fs.existsSync(daemon.log)) fs.copyFileSync(daemon.log, path.join(SHOTS, "rayd-serve.log"));
    if (tmp) fs.rmSync(tmp, { recursive: true, force: true });
  }
}, { timeout: 60_000 });

// ---- helpers -------------------------------------------------------------

async function openPage(base = daemon.base, options = {}) {
  const context = await browser.newContext({ viewport: { width: 1280, height: 900 }, acceptDownloads: true, ...options });
  context.setDefaultTimeout(STEP_MS);
  const page = await context.newPage();
  const log = { console: [], errors: [], failed: [] };
  page.on("console", (m) => log.console.push({ type: m.type(), text: m.text(), url: m.location().url }));
  page.on("pageerror", (e) => log.errors.push(String(e)));
  page.on("requestfailed", (r) => log.failed.push(`${r.method()} ${r.url()}: ${r.failure()?.errorText}`));
  const resp = await page.goto(base + "/");
  assert.equal(resp.status(), 200);
  await page.waitForFunction((a) => document.querySelectorAll(`#class-assignment option[value='${a}']`).length === 1, ASSIGNMENT);
  return { context, page, log };
}

const shot = (page, name, fullPage = true) => page.screenshot({ path: path.join(SHOTS, name + ".png"), fullPage });
const text = (page, sel) => page.locator(sel).innerText();
const consoleErrors = (log) => log.console.filter((m) => m.type === "error").map((m) => `${m.text} (${m.url})`);

// Fills the form and starts the batch; resolves with the POST's answer.
async function submit(page, { token = TOKEN, folder, archive }) {
  await page.fill("#token", token);
  await page.selectOption("#class-assignment", ASSIGNMENT);
  if (folder) await page.setInputFiles("#class-folder", folder);
  if (archive) await page.setInputFiles("#class-archive", archive);
  const answer = page.waitForResponse((r) => r.url().endsWith("/v1/grade/batch") && r.request().method() === "POST", { timeout: RENDER_MS });
  await page.click("#class-btn");
  const resp = await answer;
  await page.waitForFunction(() => !document.getElementById("class-btn").disabled, null, { timeout: RENDER_MS * 2 });
  return resp;
}

// The table as the page shows it, top to bottom.
function tableRows(page) {
  return page.$$eval("#class-table tbody tr", (trs) => trs.map((tr) => ({
    student: tr.cells[0].innerText.trim(),
    verdict: tr.cells[1].innerText.trim(),
    failed: tr.cells[2].innerText.trim(),
    psnr: tr.cells[3].innerText.trim(),
    score: tr.cells[4].innerText.trim(),
    note: tr.cells[5].innerText.trim(),
    thumb: tr.cells[5].querySelector("img")?.getAttribute("src") || null,
  })));
}

// A CSV parser for RFC 4180 (quoted fields with commas, quotes, newlines).
function parseCsv(s) {
  const rows = [];
  let row = [], f = "", q = false;
  for (let i = 0; i < s.length; i++) {
    const c = s[i];
    if (q) {
      if (c === '"' && s[i + 1] === '"') { f += '"'; i++; } else if (c === '"') q = false; else f += c;
    } else if (c === '"') q = true;
    else if (c === ",") { row.push(f); f = ""; }
    else if (c === "\n" || c === "\r") {
      if (c === "\r" && s[i + 1] === "\n") i++;
      row.push(f); rows.push(row); row = []; f = "";
    } else f += c;
  }
  if (f !== "" || row.length) { row.push(f); rows.push(row); }
  return rows;
}

function checkTable(rows, label) {
  assert.deepEqual(rows.map((r) => r.student).sort(), STUDENTS, `${label}: one row per student`);
  for (const r of rows) {
    const want = EXPECTED[r.student];
    assert.equal(r.verdict, want.verdict, `${label}: ${r.student} (${want.why}) is ${want.verdict}, the table says ${r.verdict}`);
    // phong is worth the default 1 point: a pass earns it, the rest nothing
    assert.equal(r.score, want.verdict === "PASS" ? "1.00 / 1.00" : "0.00 / 1.00", `${label}: ${r.student}'s score`);
    if (want.verdict === "ERROR") {
      assert.equal(r.failed, "—");
      assert.equal(r.thumb, null, `${r.student}: no heat map`);
      assert.match(r.note, want.message, `${r.student}: the error says why: ${r.note}`);
    } else {
      assert.match(r.failed, /^\d+\.\d{3}%$/, `${r.student}: failed % ${r.failed}`);
      assert.match(r.psnr, /^\d+\.\d{2}$/, `${r.student}: PSNR ${r.psnr}`);
      assert.ok(r.thumb && r.thumb.endsWith("/diff.png"), `${r.student}: a heat map thumbnail`);
    }
  }
}

let folderBatch = null; // { id, rows } of the folder upload, for the later tests

// ---- scenarios -----------------------------------------------------------

test("(class a) a folder of 12 students: progress while it runs, then the table the API has", { timeout: TEST_MS, skip }, async () => {
  const { context, page, log } = await openPage();
  try {
    assert.equal(await page.isVisible("#class-results"), false, "no table before a batch");
    const broken = page.locator("#class-assignment option[value='zz_broken']");
    assert.equal(await broken.isDisabled(), true, "a broken assignment cannot be picked for a class either");
    assert.match(await broken.textContent(), /zz_broken\.grade:1:8/);

    await page.fill("#token", TOKEN);
    await page.setInputFiles("#class-folder", dirs.class);
    const sel = await text(page, "#class-selection");
    assert.match(sel, /^12 files from the folder class: 12 named \.png\.$/, sel);
    await shot(page, "class-1-chosen");

    // Watch the progress bar: it must be on show, counting, before the end.
    const seen = [];
    const watch = setInterval(async () => {
      try {
        seen.push(await page.evaluate(() => ({ shown: !document.getElementById("class-progress").hidden,
          value: document.getElementById("class-bar").value, max: document.getElementById("class-bar").max,
          status: document.getElementById("class-status").textContent, rows: document.querySelectorAll("#class-table tbody tr").length })));
      } catch { /* page busy */ }
    }, 40);
    const resp = await submit(page, { folder: dirs.class });
    clearInterval(watch);
    assert.equal(resp.status(), 202, "the batch is accepted");
    const started = await resp.json();
    assert.equal(started.total, 12, "the hidden .DS_Store was not sent");
    assert.equal(started.assignment, ASSIGNMENT);
    const running = seen.filter((s) => s.shown && /^Grading/.test(s.status));
    assert.ok(running.length > 0, `the progress was shown while it ran: ${JSON.stringify(seen.slice(0, 5))}`);
    assert.ok(running.every((s) => s.max === 12 && s.value <= 12), "bar counts images out of 12");
    await shot(page, "class-2-done");

    assert.equal(await text(page, "#class-status"), "Graded 12 of 12.");
    assert.equal(await page.evaluate(() => document.getElementById("class-bar").value), 12);
    assert.match(await text(page, "#class-msg"), /every image is graded/);
    const summary = await text(page, "#class-summary");
    assert.equal(summary, `${ASSIGNMENT}: 12 of 12 graded — 4 pass, 5 fail, 3 could not be graded.`);

    const rows = await tableRows(page);
    checkTable(rows, "folder");
    assert.deepEqual(rows.map((r) => r.student), STUDENTS, "sorted by student at first");
    for (const r of rows.filter((x) => x.student === "alice" || x.student === "bob" || x.student === "carol")) {
      assert.equal(r.failed, "0.000%");
      assert.equal(r.psnr, "99.00", "identical pixels");
    }

    // The same as the API says.
    const api1 = await (await api(`/v1/grade/batch/${started.id}`, { headers: bearer() })).json();
    assert.equal(api1.status, "done");
    assert.equal(api1.results.length, 12);
    for (const r of api1.results) {
      const t = rows.find((x) => x.student === r.student);
      assert.equal(t.verdict, r.error ? "ERROR" : r.pass ? "PASS" : "FAIL", r.student);
      if (!r.error) {
        assert.equal(t.failed, (r.failed_fraction * 100).toFixed(3) + "%", r.student);
        assert.equal(t.psnr, Number(r.psnr_db).toFixed(2), r.student);
        assert.ok(t.thumb.includes(r.grade_id), `${r.student}'s thumbnail is its grade's heat map`);
      } else {
        assert.equal(r.pass, false);
        assert.ok(t.note.includes(r.error), `${r.student}: the page shows the server's message`);
      }
    }

    // Every heat map thumbnail is a loaded picture of the assignment's size.
    await page.locator("#class-table").scrollIntoViewIfNeeded();
    await page.waitForFunction(() => [...document.querySelectorAll("#class-table img.thumb")].every((i) => i.complete && i.naturalWidth > 0), null, { timeout: RENDER_MS });
    const thumbs = await page.$$eval("#class-table img.thumb", (is) => is.map((i) => [i.naturalWidth, i.naturalHeight, Math.round(i.getBoundingClientRect().width)]));
    assert.equal(thumbs.length, 9);
    for (const t of thumbs) assert.deepEqual(t, [spec.width, spec.height, 96]);
    await page.locator("#class-panel").screenshot({ path: path.join(SHOTS, "class-3-table.png") });
    folderBatch = { id: started.id, rows };

    assert.deepEqual(log.errors, [], "no uncaught script errors");
    assert.deepEqual(consoleErrors(log), [], "no console errors");
    assert.deepEqual(log.failed, [], "no failed requests");
  } finally {
    await context.close();
  }
});

test("(class b) the table sorts by each column, both ways; images not graded stay last", { timeout: TEST_MS, skip }, async () => {
  assert.ok(folderBatch, "needs (class a)");
  const { context, page } = await openPage();
  try {
    // The batch of this tab comes back after a reload; a new tab has to submit.
    await submit(page, { folder: dirs.class });
    const order = async () => (await tableRows(page)).map((r) => r.student);
    const sortBy = async (key) => page.click(`#class-table th[data-key='${key}'] button`);
    const aria = (key) => page.getAttribute(`#class-table th[data-key='${key}']`, "aria-sort");
    const rows = await tableRows(page);
    const pct = Object.fromEntries(rows.filter((r) => r.verdict !== "ERROR").map((r) => [r.student, parseFloat(r.failed)]));
    const errs = STUDENTS.filter((s) => EXPECTED[s].verdict === "ERROR");

    await sortBy("failed");
    assert.equal(await aria("failed"), "ascending");
    assert.equal(await aria("student"), "none");
    let o = await order();
    assert.deepEqual(o.slice(-3).sort(), errs, `not graded last: ${o}`);
    const graded = o.slice(0, 9);
    for (let k = 1; k < graded.length; k++) assert.ok(pct[graded[k - 1]] <= pct[graded[k]], `ascending failed %: ${graded}`);
    await shot(page, "class-4-sorted-failed");
    await sortBy("failed");
    assert.equal(await aria("failed"), "descending");
    o = await order();
    assert.deepEqual(o.slice(-3).sort(), errs, "still last");
    for (let k = 1; k < 9; k++) assert.ok(pct[o[k - 1]] >= pct[o[k]], `descending failed %: ${o}`);

    await sortBy("verdict");
    o = await order();
    const v = (s) => EXPECTED[s].verdict;
    assert.deepEqual(o.map(v), [..."PPPP"].map(() => "PASS").concat([..."FFFFF"].map(() => "FAIL"), ["ERROR", "ERROR", "ERROR"]), `pass, fail, error: ${o}`);
    await sortBy("verdict");
    assert.deepEqual((await order()).map(v), ["ERROR", "ERROR", "ERROR", "FAIL", "FAIL", "FAIL", "FAIL", "FAIL", "PASS", "PASS", "PASS", "PASS"], "descending: the worst first");

    await sortBy("psnr");
    o = await order();
    const psnr = Object.fromEntries(rows.filter((r) => r.verdict !== "ERROR").map((r) => [r.student, parseFloat(r.psnr)]));
    for (let k = 1; k < 9; k++) assert.ok(psnr[o[k - 1]] <= psnr[o[k]], `ascending PSNR: ${o}`);

    await sortBy("score");
    o = await order();
    const score = Object.fromEntries(rows.map((r) => [r.student, parseFloat(r.score)]));
    for (let k = 1; k < o.length; k++) assert.ok(score[o[k - 1]] <= score[o[k]], `ascending score: ${o}`);

    await sortBy("student");
    assert.deepEqual(await order(), STUDENTS);
    await sortBy("student");
    assert.deepEqual(await order(), [...STUDENTS].reverse());
    assert.equal(await aria("student"), "descending");
  } finally {
    await context.close();
  }
});

test("(class c) the CSV and JSON downloads are the table's rows", { timeout: TEST_MS, skip }, async () => {
  assert.ok(folderBatch, "needs (class a)");
  const { context, page, log } = await openPage();
  try {
    await submit(page, { folder: dirs.class });
    const rows = await tableRows(page);
    const [dl] = await Promise.all([page.waitForEvent("download"), page.click("#class-csv")]);
    const file = path.join(SHOTS, "results.csv");
    await dl.saveAs(file);
    assert.match(dl.suggestedFilename(), new RegExp(`^${ASSIGNMENT}-[^/]+\\.csv$`), dl.suggestedFilename());
    const csv = parseCsv(fs.readFileSync(file, "utf8"));
    assert.deepEqual(csv[0], ["student", "assignment", "pass", "failed_fraction", "max_abs", "psnr_db", "ssim", "graded_at", "grade_id", "url", "kind", "counts", "submitted_at", "late", "score", "points", "on_roster", "regrade_of", "error"], "header line");
    const body = csv.slice(1).filter((r) => r.length > 1);
    assert.equal(body.length, 12, "one line per student");
    for (const line of body) {
      const r = Object.fromEntries(csv[0].map((k, i) => [k, line[i]]));
      const t = rows.find((x) => x.student === r.student);
      assert.ok(t, `${r.student} is in the table`);
      assert.equal(r.assignment, ASSIGNMENT);
      assert.ok(r.pass === "true" || r.pass === "false", `pass is true or false: ${r.pass}`);
      assert.equal(r.pass === "true", t.verdict === "PASS", `${r.student}: pass in the CSV, ${t.verdict} in the table`);
      assert.equal(r.error !== "", t.verdict === "ERROR", `${r.student}: an error in the CSV iff the table says ERROR`);
      if (t.verdict !== "ERROR") {
        assert.equal((Number(r.failed_fraction) * 100).toFixed(3) + "%", t.failed, `${r.student}: failed %`);
        assert.equal(Number(r.psnr_db).toFixed(2), t.psnr, `${r.student}: PSNR`);
        assert.ok(!Number.isNaN(Date.parse(r.graded_at)), `${r.student}: graded_at ${r.graded_at}`);
      } else {
        assert.ok(t.note.includes(r.error), `${r.student}: the same message`);
      }
    }
    assert.ok(await page.isVisible("#class-download"), "a link to save it again");

    const [dj] = await Promise.all([page.waitForEvent("download"), page.click("#class-json")]);
    const jfile = path.join(SHOTS, "results.json");
    await dj.saveAs(jfile);
    const json = JSON.parse(fs.readFileSync(jfile, "utf8"));
    assert.ok(Array.isArray(json) && json.length === 12, "the JSON is the 12 rows");
    for (const r of json) assert.equal(r.error ? "ERROR" : r.pass ? "PASS" : "FAIL", rows.find((x) => x.student === r.student).verdict, r.student);
    assert.deepEqual(log.errors, []);
    assert.deepEqual(consoleErrors(log), []);
  } finally {
    await context.close();
  }
});

test("(class d) a click on a student shows the full verdict in the single grade's view", { timeout: TEST_MS, skip }, async () => {
  const { context, page, log } = await openPage();
  try {
    await submit(page, { folder: dirs.class });
    assert.equal(await page.isVisible("#class-detail"), false);
    const verdictAnswer = page.waitForResponse((r) => /\/v1\/grades\/[^/]+$/.test(new URL(r.url()).pathname));
    await page.click("#class-table tr[data-student='grace'] button.student");
    const v = await (await verdictAnswer).json();
    await page.locator("#cv-verdict").waitFor({ state: "visible" });
    assert.equal(await text(page, "#cv-title"), `grace — ${ASSIGNMENT}`);
    assert.equal(await text(page, "#cv-verdict"), "FAIL");
    assert.match(await page.getAttribute("#cv-verdict", "class"), /\bfail\b/);
    assert.match(await page.getAttribute("#class-table tr[data-student='grace']", "class"), /\bselected\b/);
    const m = await page.$$eval("#cv-metrics tr", (rs) => Object.fromEntries(rs.map((r) => [r.cells[0].textContent, r.cells[1].textContent])));
    assert.equal(Number(/^(\d+)/.exec(m["Failed pixels"])[1]), v.metrics.failed_pixels, "the server's count");
    assert.match(m["Failed region"], /^x \d+–\d+, y \d+–\d+$/);
    await page.waitForFunction(() => { const i = document.getElementById("cv-diff-img"); return i.complete && i.naturalWidth > 0; });
    assert.equal(await page.evaluate(() => document.getElementById("cv-diff-img").naturalWidth), spec.width);
    assert.equal(await page.getAttribute("#cv-diff-img", "src"), v.diff_url);
    const gradeId = await page.getAttribute("#class-table tr[data-student='grace']", "data-grade");
    assert.equal(await page.getAttribute("#cv-link", "href"), `/v1/grades/${gradeId}`, "a link to the verdict itself");
    // The verdict the student's own upload would have got: same view, same numbers.
    assert.equal(await page.isVisible("#verdict"), false, "the single grade's panel is left alone");
    await page.locator("#class-detail").screenshot({ path: path.join(SHOTS, "class-5-student-grace.png") });

    // Its slider and flip work as the single grade's do.
    await page.click("#cv-tab-slider");
    assert.ok(await page.isVisible("#cv-view-slider"));
    assert.equal(await page.isVisible("#cv-view-diff"), false);
    await page.waitForFunction(() => { const i = document.getElementById("cv-ref-img"); return i.complete && i.naturalWidth > 0; });
    await page.locator("#cv-slider").scrollIntoViewIfNeeded();
    const sb = await page.locator("#cv-slider").boundingBox();
    await page.mouse.click(sb.x + sb.width * 0.25, sb.y + sb.height / 2);
    const full = (await page.locator("#cv-compare").boundingBox()).width;
    const clip = await page.locator("#cv-compare-top").evaluate((e) => e.getBoundingClientRect().width);
    assert.ok(Math.abs(clip - full * Number(await page.inputValue("#cv-slider")) / 100) <= 1.5, `split follows the slider (${clip} of ${full})`);
    await page.click("#cv-tab-toggle");
    assert.match(await text(page, "#cv-flip-label"), /Showing: your image/);
    await page.click("#cv-flip-img");
    assert.match(await text(page, "#cv-flip-label"), /Showing: the reference/);
    await page.locator("#class-detail").screenshot({ path: path.join(SHOTS, "class-6-student-grace-flip.png") });

    // A passing student, then one whose image could not be graded.
    await page.click("#class-table tr[data-student='alice'] button.student");
    await page.waitForFunction(() => document.getElementById("cv-verdict").textContent === "PASS");
    assert.equal(await text(page, "#cv-title"), `alice — ${ASSIGNMENT}`);
    assert.equal(await page.isVisible("#cv-view-diff"), true, "a new verdict opens on the heat map");
    await page.click("#class-table tr[data-student='dave'] button.student");
    await page.locator("#cv-msg").waitFor({ state: "visible" });
    assert.match(await text(page, "#cv-msg"), /^Not graded: .*160x120/);
    assert.equal(await page.isVisible("#cv-verdict"), false, "no verdict for an image not graded");
    assert.equal(await page.isVisible("#cv-grade-images"), false);
    await page.click("#cv-close");
    assert.equal(await page.isVisible("#class-detail"), false);
    assert.deepEqual(log.errors, []);
    assert.deepEqual(consoleErrors(log), []);
  } finally {
    await context.close();
  }
});

test("(class e) an archive (.tar.gz) of the same images gives the same table", { timeout: TEST_MS, skip }, async () => {
  assert.ok(folderBatch, "needs (class a)");
  const { context, page } = await openPage();
  try {
    await page.setInputFiles("#class-archive", dirs.archive);
    assert.match(await text(page, "#class-selection"), /^Archive class\.tar\.gz \(\d+\.\d KiB\)\.$/);
    const resp = await submit(page, { archive: dirs.archive });
    assert.equal(resp.status(), 202);
    assert.equal((await resp.json()).total, 12);
    const rows = await tableRows(page);
    checkTable(rows, "archive");
    for (const r of rows) {
      const f = folderBatch.rows.find((x) => x.student === r.student);
      assert.deepEqual([r.verdict, r.failed, r.psnr], [f.verdict, f.failed, f.psnr], `${r.student}: as from the folder`);
    }
    await shot(page, "class-7-archive");
  } finally {
    await context.close();
  }
});

test("(class f) the token lives in the tab's sessionStorage only; a reload shows the last batch again", { timeout: TEST_MS, skip }, async () => {
  assert.ok(folderBatch, "needs (class a)");
  const { context, page } = await openPage();
  try {
    await submit(page, { folder: dirs.class });
    const store = () => page.evaluate(() => ({ session: { ...sessionStorage }, local: { ...localStorage } }));
    let s = await store();
    assert.equal(s.session["rayd.instructor-token"], TOKEN);
    assert.deepEqual(s.local, {}, "nothing in localStorage");
    const cookies = await context.cookies();
    assert.deepEqual(cookies, [], "no cookies");
    await page.reload();
    await page.waitForFunction(() => document.querySelectorAll("#class-table tbody tr").length === 12, null, { timeout: RENDER_MS });
    assert.equal(await page.inputValue("#token"), TOKEN, "the token is filled in again after a reload");
    checkTable(await tableRows(page), "after a reload");
    // Another tab does not have it.
    const other = await context.newPage();
    await other.goto(daemon.base + "/");
    assert.equal(await other.inputValue("#token"), "", "a new tab starts without the token");
    assert.equal(await other.isVisible("#class-results"), false);
    // Clearing the field forgets it.
    await page.fill("#token", "");
    s = await store();
    assert.equal(s.session["rayd.instructor-token"], undefined);
  } finally {
    await context.close();
  }
});

test("(class g) no token: 401 message; a wrong token: 403 message; no table", { timeout: TEST_MS, skip }, async () => {
  const { context, page, log } = await openPage();
  try {
    // A batch on show first: a refused one must not leave it there.
    assert.equal((await submit(page, { folder: dirs.class })).status(), 202);
    assert.ok(await page.isVisible("#class-results"));
    let resp = await submit(page, { token: "", folder: dirs.class });
    assert.equal(resp.status(), 401);
    let msg = await text(page, "#class-msg");
    assert.match(msg, /^This needs an instructor token: enter yours above/, msg);
    assert.match(await page.getAttribute("#class-msg", "class"), /\berror\b/);
    assert.equal(await page.isVisible("#class-results"), false);

    resp = await submit(page, { token: "not-the-token", folder: dirs.class });
    assert.equal(resp.status(), 403);
    msg = await text(page, "#class-msg");
    assert.match(msg, /^The server does not accept this instructor token/, msg);
    assert.equal(await page.isVisible("#class-results"), false, "no table");
    assert.equal(await page.isVisible("#class-progress"), false, "no progress");
    await page.locator("#class-panel").screenshot({ path: path.join(SHOTS, "class-8-wrong-token.png") });
    const others = consoleErrors(log).filter((t) => !/status of 40[13] .*\/v1\/grade\/batch[?)]/.test(t));
    assert.deepEqual(others, [], "no console errors besides the 401 and 403");
  } finally {
    await context.close();
  }
});

test("(class h) over --max-batch-images: 413 message; without --instructor-tokens: 404 message", { timeout: TEST_MS, skip }, async () => {
  const small = await startDaemon(path.join(tmp, "small"), ["--scenes", "scenes", "--assignments", dirs.assignments,
    "--instructor-tokens", dirs.tokens, "--max-batch-images", "5"]);
  const off = await startDaemon(path.join(tmp, "off"), ["--scenes", "scenes", "--assignments", dirs.assignments]);
  try {
    let { context, page } = await openPage(small.base);
    try {
      const resp = await submit(page, { folder: dirs.class });
      assert.equal(resp.status(), 413);
      const msg = await text(page, "#class-msg");
      assert.match(msg, /^Too large for the server: /, msg);
      assert.match(msg, /max-batch-images/, `names the limit: ${msg}`);
      await page.locator("#class-panel").screenshot({ path: path.join(SHOTS, "class-9-too-many.png") });
    } finally {
      await context.close();
    }
    ({ context, page } = await openPage(off.base));
    try {
      const resp = await submit(page, { folder: dirs.class });
      assert.equal(resp.status(), 404);
      const msg = await text(page, "#class-msg");
      assert.match(msg, /does not grade classes: it was started without --instructor-tokens/, msg);
      await page.locator("#class-panel").screenshot({ path: path.join(SHOTS, "class-10-off.png") });
      // The rest of the page works as ever there.
      assert.equal(await page.locator("#assignment-pick option[value='phong']").count(), 1);
    } finally {
      await context.close();
    }
  } finally {
    await stopDaemon(small);
    await stopDaemon(off);
  }
});

test("(class j) a new tab lists the batches, opens one, cancels a running one and deletes a finished one", { timeout: TEST_MS, skip }, async () => {
  const { context, page, log } = await openPage();
  try {
    const started = await (await submit(page, { folder: dirs.class })).json();
    const row = (id) => page.locator(`#past-table tbody tr[data-id='${id}']`);
    await row(started.id).waitFor();
    // Another tab: nothing on show until the list is asked for.
    const other = await context.newPage();
    other.on("dialog", (d) => d.accept());
    await other.goto(daemon.base + "/");
    await other.fill("#token", TOKEN);
    await other.click("#past-btn");
    const mine = other.locator(`#past-table tbody tr[data-id='${started.id}']`);
    await mine.waitFor();
    assert.deepEqual(await mine.locator("td").allInnerTexts().then((t) => t.slice(1, 4)), [ASSIGNMENT, "done", "12 of 12"]);
    await mine.getByRole("button", { name: "Open" }).click();
    await other.waitForFunction(() => document.querySelectorAll("#class-table tbody tr").length === 12);
    checkTable(await tableRows(other), "opened from the list");
    await other.locator("#class-panel").screenshot({ path: path.join(SHOTS, "class-12-listed.png") });

    // A batch big enough to be running when its Cancel is clicked.
    const png = fs.readFileSync(path.join(dirs.class, "alice.png"));
    const form = new FormData();
    form.append("assignment", ASSIGNMENT);
    for (let i = 0; i < 450; i++) form.append("image", new Blob([png], { type: "image/png" }), `s${i}.png`);
    const posted = await api("/v1/grade/batch", { method: "POST", headers: bearer(), body: form });
    assert.equal(posted.status, 202, "450 images, within --max-batch-images");
    const big = await posted.json();
    await other.click("#past-btn");
    const running = other.locator(`#past-table tbody tr[data-id='${big.id}']`);
    await running.getByRole("button", { name: "Cancel" }).click();
    await other.waitForFunction((id) => document.querySelector(`#past-table tbody tr[data-id='${id}'] td:nth-child(3)`)?.innerText === "cancelled", big.id);
    assert.match(await text(other, "#past-msg"), /^Cancelled/);
    const cancelled = await (await api(`/v1/grade/batch/${big.id}`, { headers: bearer() })).json();
    assert.equal(cancelled.status, "cancelled");
    assert.ok(cancelled.done < 450, `cancelled at ${cancelled.done} of 450`);

    // Delete (confirmed): the batch on show goes, and its records.
    const ids = (await (await api(`/v1/grade/batch/${started.id}`, { headers: bearer() })).json()).results.map((r) => r.grade_id);
    await mine.getByRole("button", { name: "Delete" }).click();
    await mine.waitFor({ state: "detached" });
    assert.match(await text(other, "#past-msg"), /^Deleted/);
    assert.equal(await other.isVisible("#class-results"), false, "the deleted batch is no longer on show");
    assert.equal((await api(`/v1/grade/batch/${started.id}`, { headers: bearer() })).status, 404);
    for (const id of ids) assert.equal((await api(`/v1/grades/${id}`)).status, 404, `record ${id} went with its batch`);
    await other.locator("#class-panel").screenshot({ path: path.join(SHOTS, "class-13-deleted.png") });
    assert.deepEqual(log.errors, [], "no uncaught script errors");
  } finally {
    await context.close();
  }
});

test("(class i) at phone width the class view fits the screen", { timeout: TEST_MS, skip }, async () => {
  const { context, page } = await openPage(daemon.base, { viewport: { width: 375, height: 740 }, deviceScaleFactor: 2, isMobile: true, hasTouch: true });
  try {
    await submit(page, { folder: dirs.class });
    const w = await page.evaluate(() => document.documentElement.scrollWidth);
    assert.ok(w <= 376, `no sideways scrolling with the table on show (scrollWidth ${w})`);
    const p = await page.locator("#class-panel").boundingBox();
    assert.ok(p.x >= 0 && p.x + p.width <= 375, "the panel is inside the screen");
    await page.locator("#class-results").scrollIntoViewIfNeeded();
    await shot(page, "class-11-phone", false);
  } finally {
    await context.close();
  }
});
