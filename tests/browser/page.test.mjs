// Browser test of the page rayd serves at GET / (daemon/http/web/index.html).
//
// Starts the real daemon (`$RAYD serve`, RAYD defaults to build/rayd) on a
// free loopback port, renders the grading images with the CLI, and drives
// Debian's /usr/bin/chromium through playwright-core the way a person uses
// the page: pick, type, click, upload, drag, look. Screenshots of every step
// go to build/browser-screenshots/.
//
// Run from the repository root: tests/browser/run.sh (or `node --test tests/browser/`).

import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import { spawn, execFile } from "node:child_process";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { fileURLToPath } from "node:url";
import { chromium } from "playwright-core";

const HERE = path.dirname(fileURLToPath(import.meta.url));
const ROOT = path.resolve(HERE, "..", "..");
const RAYD = path.resolve(process.cwd(), process.env.RAYD || path.join(ROOT, "build", "rayd"));
const CHROMIUM = process.env.CHROMIUM || "/usr/bin/chromium";
const SHOTS = path.join(ROOT, "build", "browser-screenshots");

const RENDER_MS = 60_000; // renders and grades: 2 busy cores
const STEP_MS = 20_000; // everything else a page does
const TEST_MS = 180_000; // one scenario, whole

let tmp; // scratch folder: port file, PNGs, daemon log
let daemon; // the rayd serve child process
let daemonLog;
let base; // http://127.0.0.1:PORT
let browser;
const files = {}; // PASS.png, FAIL.png, x.png

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

function daemonLogTail(n = 20) {
  try {
    return fs.readFileSync(daemonLog, "utf8").trim().split("\n").slice(-n).join("\n");
  } catch {
    return "(no log)";
  }
}

function killDaemonNow() {
  if (daemon && daemon.exitCode === null && daemon.signalCode === null) {
    try { process.kill(daemon.pid, "SIGKILL"); } catch { /* gone */ }
  }
}
// Never leave a daemon behind, whatever ends this process.
process.on("exit", killDaemonNow);
for (const sig of ["SIGINT", "SIGTERM", "SIGHUP"]) {
  process.once(sig, () => { killDaemonNow(); process.exit(128 + os.constants.signals[sig]); });
}

async function stopDaemon() {
  if (!daemon || daemon.exitCode !== null || daemon.signalCode !== null) return null;
  const exited = new Promise((r) => daemon.once("exit", (code, signal) => r({ code, signal })));
  process.kill(daemon.pid, "SIGTERM");
  let res = await Promise.race([exited, sleep(15_000).then(() => null)]);
  if (!res) {
    process.kill(daemon.pid, "SIGKILL");
    res = await Promise.race([exited, sleep(5_000).then(() => null)]);
    if (res) res.killed = true;
  }
  return res;
}

function run(cmd, args) {
  return new Promise((resolve, reject) => {
    execFile(cmd, args, { cwd: ROOT, timeout: RENDER_MS }, (err, stdout, stderr) => {
      if (err) reject(new Error(`${cmd} ${args.join(" ")} failed: ${err.message}\n${stderr}`));
      else resolve({ stdout, stderr });
    });
  });
}

function pngSize(file) {
  const b = fs.readFileSync(file);
  assert.equal(b.subarray(1, 4).toString("latin1"), "PNG", `${file} is a PNG`);
  return { width: b.readUInt32BE(16), height: b.readUInt32BE(20) };
}

before(async () => {
  assert.ok(fs.existsSync(RAYD), `no daemon binary at ${RAYD}: build it with 'make build/rayd' (or set RAYD)`);
  assert.ok(fs.existsSync(CHROMIUM), `no Chromium at ${CHROMIUM}: apt-get install -y chromium`);
  tmp = fs.mkdtempSync(path.join(os.tmpdir(), "rayd-browser-"));
  fs.mkdirSync(SHOTS, { recursive: true });
  for (const f of fs.readdirSync(SHOTS)) if (f.endsWith(".png") || f.endsWith(".log")) fs.rmSync(path.join(SHOTS, f));

  // The grading images, made with the CLI: PASS is the reference itself,
  // FAIL is the diffuse scene (same size and camera, wrong shading).
  files.pass = path.join(tmp, "PASS.png");
  files.fail = path.join(tmp, "FAIL.png");
  await run(RAYD, ["render", "scenes/assignments/phong.cfg", "-o", files.pass]);
  await run(RAYD, ["render", "scenes/assignments/diffuse.cfg", "-o", files.fail]);
  assert.deepEqual(pngSize(files.pass), { width: 320, height: 240 });
  assert.deepEqual(pngSize(files.fail), { width: 320, height: 240 });
  files.small = path.join(tmp, "small.png"); // right scene, wrong size
  await run(RAYD, ["render", "scenes/assignments/phong.cfg", "-o", files.small, "--width", "160", "--height", "120"]);
  assert.deepEqual(pngSize(files.small), { width: 160, height: 120 });
  files.notPng = path.join(tmp, "x.png"); // a cfg scene with a .png name
  fs.copyFileSync(path.join(ROOT, "scenes/assignments/phong.cfg"), files.notPng);

  const portFile = path.join(tmp, "port");
  daemonLog = path.join(tmp, "rayd-serve.log");
  const logFd = fs.openSync(daemonLog, "w");
  // The course's assignments and one whose .grade file is broken.
  const assignments = path.join(tmp, "assignments");
  fs.cpSync(path.join(ROOT, "scenes/assignments"), assignments, { recursive: true });
  fs.copyFileSync(path.join(ROOT, "scenes/assignments/phong.cfg"), path.join(assignments, "zz_broken.cfg"));
  fs.writeFileSync(path.join(assignments, "zz_broken.grade"), "fail = banana\n");
  daemon = spawn(RAYD, ["serve", "--listen", "127.0.0.1:0", "--port-file", portFile,
    "--scenes", "scenes", "--assignments", assignments, "--data-dir", path.join(tmp, "var")],
  { cwd: ROOT, stdio: ["ignore", "ignore", logFd] });
  fs.closeSync(logFd);
  const t0 = Date.now();
  let port = 0;
  while (!port) {
    if (daemon.exitCode !== null || daemon.signalCode !== null) {
      throw new Error(`rayd serve exited (${daemon.exitCode ?? daemon.signalCode}) before listening:\n${daemonLogTail()}`);
    }
    if (Date.now() - t0 > 30_000) {
      await stopDaemon();
      throw new Error(`rayd serve wrote no port file in 30 s:\n${daemonLogTail()}`);
    }
    try {
      const text = fs.readFileSync(portFile, "utf8");
      if (/^\d+\s*$/.test(text)) port = Number(text);
    } catch { /* not yet */ }
    if (!port) await sleep(50);
  }
  base = `http://127.0.0.1:${port}`;

  // Chromium from Debian; playwright gives it a new empty profile of its own.
  browser = await chromium.launch({
    executablePath: CHROMIUM,
    args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
      "--disable-background-networking", "--disable-component-update", "--disable-sync"],
    timeout: 60_000,
  });
}, { timeout: 300_000 });

after(async () => {
  try {
    if (browser) await browser.close();
  } finally {
    const res = await stopDaemon();
    if (res && (res.code !== 0 || res.killed)) {
      console.log(`# rayd serve did not stop cleanly on SIGTERM: ${JSON.stringify(res)}\n${daemonLogTail()}`);
    }
    if (daemonLog && fs.existsSync(daemonLog)) fs.copyFileSync(daemonLog, path.join(SHOTS, "rayd-serve.log"));
    if (tmp) fs.rmSync(tmp, { recursive: true, force: true });
  }
}, { timeout: 60_000 });

// ---- helpers -------------------------------------------------------------

// A new page in a new context, with everything the console says kept.
async function openPage(options = {}) {
  const context = await browser.newContext({ viewport: { width: 1280, height: 900 }, ...options });
  context.setDefaultTimeout(STEP_MS);
  const page = await context.newPage();
  const log = { console: [], errors: [], failed: [] };
  page.on("console", (m) => log.console.push({ type: m.type(), text: m.text(), url: m.location().url }));
  page.on("pageerror", (e) => log.errors.push(String(e)));
  page.on("requestfailed", (r) => log.failed.push(`${r.method()} ${r.url()}: ${r.failure()?.errorText}`));
  const resp = await page.goto(base + "/");
  assert.equal(resp.status(), 200, "GET / answers 200");
  // Both lists are filled from the API when the page starts.
  await page.waitForFunction(() => document.querySelectorAll("#scene-pick option").length > 1);
  await page.waitForFunction(() => document.querySelectorAll("#assignment-pick option[value='phong']").length === 1);
  return { context, page, log };
}

// Console errors, less Chromium's own 404 for /favicon.ico (a known defect,
// tested on its own below; it comes and goes with timing).
const consoleErrors = (log) => log.console
  .filter((m) => m.type === "error")
  .map((m) => `${m.text} (${m.url})`);

// The whole page, or (fullPage false) what the screen shows now.
async function shot(page, name, fullPage = true) {
  await page.screenshot({ path: path.join(SHOTS, name + ".png"), fullPage });
}

// What a person would see of an <img>: shown or not, loaded or not, its size.
function image(page, id) {
  return page.evaluate((id) => {
    const i = document.getElementById(id);
    const r = i.getBoundingClientRect();
    return {
      src: i.getAttribute("src"), hidden: i.hidden || i.closest("[hidden]") !== null,
      complete: i.complete, naturalWidth: i.naturalWidth, naturalHeight: i.naturalHeight,
      shownWidth: r.width, shownHeight: r.height,
    };
  }, id);
}

// Waits until the <img> shows a loaded picture whose src ends with `src` (any, if not given).
async function imageLoaded(page, id, src, timeout = STEP_MS) {
  await page.waitForFunction(([id, src]) => {
    const i = document.getElementById(id);
    return i.complete && i.naturalWidth > 0 && (!src || (i.getAttribute("src") || "").endsWith(src));
  }, [id, src], { timeout });
  return image(page, id);
}

// Runs in the page: an <img> as shown, with its distinct colours (a blank
// or black picture has one). With `points`, null until the image is loaded
// and the error curve has that many points: a waitForFunction measures the
// image in the moment it is seen loaded.
function shownImage({ id, points = 0 }) {
  const i = document.getElementById(id);
  if (points && (Number(document.getElementById("curve").dataset.points || 0) < points || !i.complete ||
    i.naturalWidth === 0)) return null;
  const c = document.createElement("canvas");
  c.width = i.naturalWidth; c.height = i.naturalHeight;
  const g = c.getContext("2d");
  g.drawImage(i, 0, 0);
  const d = g.getImageData(0, 0, c.width, c.height).data;
  const seen = new Set();
  for (let p = 0; p < d.length; p += 4) seen.add((d[p] << 16) | (d[p + 1] << 8) | d[p + 2]);
  return { naturalWidth: i.naturalWidth, hidden: i.hidden || i.closest("[hidden]") !== null, src: i.getAttribute("src"),
    colours: seen.size };
}

// Distinct colours in a loaded image.
async function colours(page, id) {
  return (await page.evaluate(shownImage, { id })).colours;
}

const box = (page, sel) => page.locator(sel).evaluate((e) => {
  const r = e.getBoundingClientRect();
  return { left: r.left, right: r.right, top: r.top + scrollY, bottom: r.bottom + scrollY, width: r.width, height: r.height };
});

const text = (page, sel) => page.locator(sel).innerText();

async function renderAndWait(page) {
  await page.click("#render-btn");
  await page.waitForFunction(() => {
    const m = document.getElementById("render-msg");
    return !document.getElementById("render-btn").disabled && m.textContent !== "Rendering…";
  }, null, { timeout: RENDER_MS });
}

async function gradeAndWait(page, assignment, file) {
  await page.selectOption("#assignment-pick", assignment);
  await page.setInputFiles("#grade-file", file);
  const answer = page.waitForResponse((r) => r.url().endsWith("/v1/grade"), { timeout: RENDER_MS });
  await page.click("#grade-btn");
  const resp = await answer;
  await page.waitForFunction(() => !document.getElementById("grade-btn").disabled, null, { timeout: RENDER_MS });
  return resp;
}

// Metrics table rows as { label: value }.
function metrics(page) {
  return page.$$eval("#metrics tr", (rows) => Object.fromEntries(
    rows.map((r) => [r.cells[0].textContent, r.cells[1].textContent])));
}

// ---- scenarios -----------------------------------------------------------

test("(a) page loads cleanly, an example scene fills the editor, Render shows the image and its stats", { timeout: TEST_MS }, async () => {
  const { context, page, log } = await openPage();
  try {
    assert.equal(await page.title(), "rayd");
    assert.equal(await text(page, "h1"), "rayd");
    const names = await page.$$eval("#scene-pick option", (os) => os.map((o) => o.textContent));
    assert.ok(names.includes("phong.cfg"), `example list has phong.cfg: ${names.join(", ")}`);
    assert.ok(names.includes("phong.json"), "example list has the JSON scenes too");
    assert.equal(await page.inputValue("#scene-text"), "", "editor starts empty");
    assert.equal(await text(page, "#render-stats"), "No render yet.");
    // (Whether an empty image box shows before a render: see the test at the end.)
    // Wide screen: scene and image side by side, grading under both.
    const s = await box(page, "#scene-panel"), i = await box(page, "#image-panel"), g = await box(page, "#grade-panel");
    assert.ok(i.left >= s.right && Math.abs(i.top - s.top) < 2, "scene and image panels side by side at 1280 px");
    assert.ok(g.top >= Math.max(s.bottom, i.bottom), "grading panel below them");
    await shot(page, "a1-loaded");

    await page.selectOption("#scene-pick", { label: "phong.cfg" });
    const want = fs.readFileSync(path.join(ROOT, "scenes/phong.cfg"), "utf8").replace(/\r\n/g, "\n");
    await page.waitForFunction(() => document.getElementById("scene-text").value.length > 0);
    assert.equal(await page.inputValue("#scene-text"), want, "editor holds scenes/phong.cfg");
    await page.fill("#width", "160");
    await page.fill("#height", "120");
    await shot(page, "a2-phong-chosen");

    await renderAndWait(page);
    assert.equal(await text(page, "#render-msg"), "Done.");
    assert.match(await page.getAttribute("#render-msg", "class"), /\bok\b/);
    const img = await imageLoaded(page, "render-img");
    assert.equal(img.hidden, false, "image shown");
    assert.equal(img.naturalWidth, 160);
    assert.equal(img.naturalHeight, 120);
    assert.ok(img.shownWidth > 100, `image drawn on the page (${img.shownWidth} px wide)`);
    assert.ok(await colours(page, "render-img") > 100, "the picture is a rendering, not a blank");
    const stats = await text(page, "#render-stats");
    assert.match(stats, /Rendered in \d+(\.\d+)? ms/, stats);
    assert.match(stats, /\b\d+ samples? per pixel/, stats);
    assert.doesNotMatch(stats, /NaN|null|undefined/, stats);
    await shot(page, "a3-rendered");

    assert.deepEqual(log.errors, [], "no uncaught script errors");
    assert.deepEqual(consoleErrors(log), [], "no console errors");
    assert.deepEqual(log.failed, [], "no failed requests");
  } finally {
    await context.close();
  }
});

test("(b) a broken scene shows the parse error in words, with line:column, and leaves the image alone", { timeout: TEST_MS }, async () => {
  const { context, page, log } = await openPage();
  try {
    const broken = "[render]\nwidth = 64O";
    await page.fill("#scene-text", broken);
    await renderAndWait(page);
    let msg = await text(page, "#render-msg");
    assert.ok(await page.isVisible("#render-msg"), "error shown");
    assert.match(await page.getAttribute("#render-msg", "class"), /\berror\b/);
    assert.ok(msg.includes("2:9") && msg.includes("64O"), `message names the place and the text: ${msg}`);
    assert.match(msg, /width/, "message names the key");
    assert.equal(await page.getAttribute("#render-img", "src"), null, "still no image");
    assert.equal(await text(page, "#render-stats"), "No render yet.");
    await shot(page, "b1-broken-first");

    // With an image on show, a broken scene must not replace or hide it.
    await page.fill("#scene-text", fs.readFileSync(path.join(ROOT, "scenes/phong.cfg"), "utf8"));
    await page.fill("#width", "160");
    await page.fill("#height", "120");
    await renderAndWait(page);
    const good = await imageLoaded(page, "render-img");
    const goodStats = await text(page, "#render-stats");
    assert.equal(good.naturalWidth, 160);

    await page.fill("#scene-text", broken);
    await renderAndWait(page);
    msg = await text(page, "#render-msg");
    assert.ok(msg.includes("2:9") && msg.includes("64O"), msg);
    const still = await image(page, "render-img");
    assert.equal(still.src, good.src, "same image");
    assert.equal(still.hidden, false, "image still shown");
    assert.equal(still.naturalWidth, 160);
    assert.equal(await text(page, "#render-stats"), goodStats, "stats unchanged");
    assert.equal(await page.inputValue("#scene-text"), broken, "the text the person typed is kept");
    await shot(page, "b2-broken-after-image");

    assert.deepEqual(log.errors, [], "no uncaught script errors");
    // Chromium logs each 4xx answer to fetch(); nothing else may appear.
    const others = consoleErrors(log).filter((t) => !/status of 400 .*\/v1\/jobs[?)]/.test(t));
    assert.deepEqual(others, [], "no console errors besides the two 400 answers");
  } finally {
    await context.close();
  }
});

test("(c) grading: PASS and FAIL verdicts, metrics, heat map, slider and flip views", { timeout: TEST_MS }, async () => {
  const { context, page, log } = await openPage();
  try {
    await page.selectOption("#assignment-pick", "phong");
    const info = await text(page, "#assignment-info");
    assert.match(info, /320×240/, info);
    assert.equal(await page.isVisible("#grade-images"), false, "no comparison before a grade");

    // PASS: the reference itself.
    let resp = await gradeAndWait(page, "phong", files.pass);
    assert.equal(resp.status(), 200);
    let v = await resp.json();
    await page.locator("#verdict").waitFor({ state: "visible" });
    assert.equal(await text(page, "#verdict"), "PASS");
    assert.match(await page.getAttribute("#verdict", "class"), /\bpass\b/);
    assert.ok(await page.isVisible("#metrics"), "metrics table shown");
    let m = await metrics(page);
    assert.match(m["Failed pixels"], /^0 \(0\.000%/, m["Failed pixels"]);
    assert.match(m["SSIM"], /^1\.0+$/);
    assert.equal(m["Failed region"], "none");
    assert.equal(await page.isVisible("#grade-msg"), false, "no message left over");
    let diff = await imageLoaded(page, "diff-img", v.diff_url, RENDER_MS);
    assert.equal(diff.naturalWidth, 320, "heat map at the assignment's size");
    assert.equal(diff.naturalHeight, 240);
    assert.ok(await page.isVisible("#diff-img"), "heat map shown");
    assert.equal(await page.getAttribute("#tab-diff", "class"), "on");
    await shot(page, "c1-pass");

    // FAIL: diffuse shading where Phong belongs.
    resp = await gradeAndWait(page, "phong", files.fail);
    v = await resp.json();
    await page.locator("#verdict").waitFor({ state: "visible" });
    assert.equal(await text(page, "#verdict"), "FAIL");
    assert.match(await page.getAttribute("#verdict", "class"), /\bfail\b/);
    m = await metrics(page);
    const failed = Number(/^(\d+)/.exec(m["Failed pixels"])?.[1]);
    assert.ok(failed > 0, `failed pixels > 0: ${m["Failed pixels"]}`);
    assert.equal(failed, v.metrics.failed_pixels, "table shows the server's count");
    assert.match(m["Failed region"], /^x \d+–\d+, y \d+–\d+$/, m["Failed region"]);
    assert.match(m["Largest difference"], /levels at \(\d+, \d+\): expected \d+ \d+ \d+, got \d+ \d+ \d+/);
    diff = await imageLoaded(page, "diff-img", v.diff_url, RENDER_MS);
    assert.equal(diff.naturalWidth, 320);
    assert.ok(await colours(page, "diff-img") > 10, "heat map has colour in it");
    await shot(page, "c2-fail");

    // Slider: your image left of the split, the reference right of it.
    await page.click("#tab-slider");
    assert.ok(await page.isVisible("#view-slider"), "slider view shown");
    assert.equal(await page.isVisible("#view-diff"), false, "heat map view hidden");
    assert.equal(await page.getAttribute("#tab-slider", "class"), "on");
    const ref = await imageLoaded(page, "ref-img", v.reference_url);
    const mine = await imageLoaded(page, "mine-img", v.image_url);
    assert.equal(ref.naturalWidth, 320);
    assert.equal(mine.naturalWidth, 320);
    assert.ok(ref.shownWidth > 100 && mine.shownWidth > 100, "both images drawn");
    assert.ok(Math.abs(mine.shownWidth - ref.shownWidth) <= 1, `your image drawn at the reference's size (${mine.shownWidth} vs ${ref.shownWidth})`);
    const clip = () => page.locator("#compare-top").evaluate((e) => e.getBoundingClientRect().width);
    const full = (await box(page, "#compare")).width;
    const clip50 = await clip();
    assert.ok(Math.abs(clip50 - full / 2) <= 1.5, `split starts in the middle (${clip50} of ${full})`);
    await shot(page, "c3-slider-50");

    // Drag the slider's thumb to a quarter of the way, as a person would.
    await page.locator("#slider").scrollIntoViewIfNeeded();
    const sb = await page.locator("#slider").boundingBox();
    await page.mouse.move(sb.x + sb.width / 2, sb.y + sb.height / 2);
    await page.mouse.down();
    await page.mouse.move(sb.x + sb.width * 0.25, sb.y + sb.height / 2, { steps: 5 });
    await page.mouse.up();
    const val = Number(await page.inputValue("#slider"));
    assert.ok(val > 15 && val < 35, `slider moved to about 25 (${val})`);
    const clip25 = await clip();
    assert.ok(clip25 < clip50 - 10, `clip narrower after the drag (${clip25} < ${clip50})`);
    assert.ok(Math.abs(clip25 - full * val / 100) <= 1.5, `clip follows the slider (${clip25} ≈ ${full * val / 100})`);
    await shot(page, "c4-slider-dragged");
    // And with the keyboard.
    await page.focus("#slider");
    await page.keyboard.press("End");
    assert.ok(Math.abs(await clip() - full) <= 1.5, "End: all of your image");
    await page.keyboard.press("Home");
    assert.ok(await clip() <= 0.5, "Home: all of the reference");

    // Flip: one picture, your image or the reference, changed by a click.
    await page.click("#tab-toggle");
    assert.ok(await page.isVisible("#view-toggle"), "flip view shown");
    assert.equal(await page.isVisible("#view-slider"), false, "slider view hidden");
    let flip = await imageLoaded(page, "flip-img", v.image_url);
    assert.equal(flip.naturalWidth, 320);
    assert.match(await text(page, "#flip-label"), /Showing: your image/);
    await shot(page, "c5-flip-mine");
    await page.click("#flip-img");
    flip = await imageLoaded(page, "flip-img", v.reference_url);
    assert.match(await text(page, "#flip-label"), /Showing: the reference/);
    await shot(page, "c6-flip-reference");
    await page.click("#flip-img");
    flip = await imageLoaded(page, "flip-img", v.image_url);
    assert.match(await text(page, "#flip-label"), /Showing: your image/);

    await page.click("#tab-diff");
    assert.ok(await page.isVisible("#diff-img"), "back to the heat map");

    assert.deepEqual(log.errors, [], "no uncaught script errors");
    assert.deepEqual(consoleErrors(log), [], "no console errors");
    assert.deepEqual(log.failed, [], "no failed requests");
  } finally {
    await context.close();
  }
});

test("(d) a file that is not a PNG, or of the wrong size, gets a clear message, not a verdict", { timeout: TEST_MS }, async () => {
  const { context, page, log } = await openPage();
  try {
    // Nothing chosen yet: the page says so without asking the server.
    await page.click("#grade-btn");
    assert.match(await text(page, "#grade-msg"), /Choose your PNG file first/);

    const resp = await gradeAndWait(page, "phong", files.notPng);
    assert.equal(resp.status(), 415, "the server refuses it with 415");
    assert.ok(await page.isVisible("#grade-msg"), "message shown");
    assert.match(await page.getAttribute("#grade-msg", "class"), /\berror\b/);
    const msg = await text(page, "#grade-msg");
    assert.match(msg, /not a PNG/, msg);
    assert.equal(await page.isVisible("#verdict"), false, "no verdict");
    assert.equal(await page.isVisible("#metrics"), false, "no metrics");
    assert.equal(await page.isVisible("#grade-images"), false, "no images");
    await shot(page, "d1-not-png");

    assert.deepEqual(log.errors, [], "no uncaught script errors");

    // A PNG of the wrong size: 422, and the message gives both sizes.
    const r2 = await gradeAndWait(page, "phong", files.small);
    assert.equal(r2.status(), 422);
    const msg2 = await text(page, "#grade-msg");
    assert.match(msg2, /160x120/, msg2);
    assert.match(msg2, /320x240/, msg2);
    assert.equal(await page.isVisible("#verdict"), false, "no verdict");
    await shot(page, "d2-wrong-size");

    const others = consoleErrors(log).filter((t) => !/status of (415|422) .*\/v1\/grade[?)]/.test(t));
    assert.deepEqual(others, [], "no console errors besides the 415 and 422 answers");
  } finally {
    await context.close();
  }
});

test("(e) at phone width (375×740) the panels stack and nothing scrolls sideways", { timeout: TEST_MS }, async () => {
  const { context, page, log } = await openPage({
    viewport: { width: 375, height: 740 }, deviceScaleFactor: 2, isMobile: true, hasTouch: true,
  });
  const noSideScroll = async (when) => {
    const w = await page.evaluate(() => ({ scroll: document.documentElement.scrollWidth, client: document.documentElement.clientWidth }));
    assert.ok(w.scroll <= 375 + 1, `no horizontal scrolling ${when}: scrollWidth ${w.scroll}`);
    assert.equal(w.client, 375, `layout viewport is the phone's width ${when}`);
  };
  try {
    await noSideScroll("on load");
    const panels = [];
    for (const id of ["#scene-panel", "#image-panel", "#grade-panel"]) panels.push(await box(page, id));
    for (let k = 0; k < panels.length; k++) {
      assert.ok(panels[k].left >= 0 && panels[k].right <= 375, `panel ${k} inside the screen`);
      assert.ok(panels[k].width > 300, `panel ${k} uses the width (${panels[k].width})`);
      if (k) {
        assert.ok(Math.abs(panels[k].left - panels[0].left) < 1, `panel ${k} in the same column`);
        assert.ok(panels[k].top >= panels[k - 1].bottom, `panel ${k} below panel ${k - 1}`);
      }
    }
    await shot(page, "e1-phone-loaded");

    // A full-size render fits the screen.
    await page.selectOption("#scene-pick", { label: "phong.cfg" });
    await page.waitForFunction(() => document.getElementById("scene-text").value.length > 0);
    await page.fill("#width", "320");
    await page.fill("#height", "240");
    await renderAndWait(page);
    const img = await imageLoaded(page, "render-img");
    assert.equal(img.naturalWidth, 320);
    assert.ok(img.shownWidth <= 375, `image fits (${img.shownWidth} px)`);
    await noSideScroll("after a render");
    await shot(page, "e2-phone-rendered");
    await page.locator("#image-panel").scrollIntoViewIfNeeded();
    await shot(page, "e2-phone-rendered-screen", false);

    // Grading output: table, heat map, slider and flip, stacked in one column.
    const resp = await gradeAndWait(page, "phong", files.fail);
    const v = await resp.json();
    await imageLoaded(page, "diff-img", v.diff_url, RENDER_MS);
    const form = await box(page, "#metrics"), pics = await box(page, "#grade-images");
    assert.ok(pics.top >= form.bottom, "comparison below the metrics on a phone");
    assert.ok(pics.right <= 375 && form.right <= 375, "both inside the screen");
    await noSideScroll("after grading");
    await shot(page, "e3-phone-graded");
    await page.evaluate(() => document.getElementById("verdict").scrollIntoView({ block: "start" }));
    await shot(page, "e3-phone-graded-screen", false);
    await page.click("#tab-slider");
    await imageLoaded(page, "ref-img", v.reference_url);
    await noSideScroll("in the slider view");
    await page.locator("#slider").scrollIntoViewIfNeeded();
    const sb = await page.locator("#slider").boundingBox();
    await page.touchscreen.tap(sb.x + sb.width * 0.8, sb.y + sb.height / 2);
    const val = Number(await page.inputValue("#slider"));
    assert.ok(val > 70 && val < 90, `a tap moves the slider to about 80 (${val})`);
    await noSideScroll("after moving the slider");
    await page.evaluate(() => document.getElementById("grade-images").scrollIntoView({ block: "start" }));
    await shot(page, "e4-phone-slider-screen", false);
    await page.click("#tab-toggle");
    await imageLoaded(page, "flip-img", v.image_url);
    await noSideScroll("in the flip view");
    await shot(page, "e5-phone-flip-screen", false);

    assert.deepEqual(log.errors, [], "no uncaught script errors");
    assert.deepEqual(consoleErrors(log), [], "no console errors");
  } finally {
    await context.close();
  }
});

test("(g) a long render shows its progress, each pass's image and the error curve as they come; Cancel stops it", { timeout: TEST_MS }, async () => {
  const { context, page, log } = await openPage();
  const partials = [];
  page.on("request", (r) => { if (/\/v1\/jobs\/[0-9a-f]+\/image\?partial=1$/.test(r.url())) partials.push(r.url()); });
  try {
    await page.selectOption("#scene-pick", { label: "area_light.cfg" });
    await page.waitForFunction(() => document.getElementById("scene-text").value.includes("area"));
    await page.fill("#width", "320");
    await page.fill("#height", "240");
    await page.fill("#samples", "1024"); // minutes of work: it must be stopped
    assert.equal(await page.isChecked("#progressive"), true, "passes are on by default");
    assert.equal(await page.isVisible("#render-progress"), false, "no progress before a render");
    const posted = page.waitForResponse((r) => r.url().includes("/v1/jobs?") && r.request().method() === "POST");
    await page.click("#render-btn");
    const resp = await posted;
    assert.equal(resp.status(), 202, "the render is a job");
    const id = (await resp.json()).id;
    assert.match(id, /^[0-9a-f]{32}$/);
    assert.match(resp.url(), /[?&]time_budget_ms=/, "asked for passes");
    await page.locator("#render-progress").waitFor({ state: "visible" });
    assert.equal(await text(page, "#render-msg"), "Rendering…");
    assert.equal(await page.isEnabled("#cancel-btn"), true);

    // Two passes: two points on the curve, and the image of a pass on show.
    // The page swaps in each new pass's image as it comes, so the image is
    // measured in the same moment it is seen loaded: a read after the wait
    // may find the next pass's image still loading (naturalWidth 0).
    const img = await (await page.waitForFunction(shownImage, { id: "render-img", points: 2 }, { timeout: RENDER_MS })).jsonValue();
    assert.equal(img.naturalWidth, 320, "the partial image is the full size");
    assert.equal(img.hidden, false);
    assert.ok(img.src.startsWith("blob:"), "drawn from a fetched partial image");
    assert.ok(partials.length >= 1 && partials.every((u) => u.includes(id)), `asked for ?partial=1 images: ${partials.length}`);
    assert.ok(img.colours > 50, "the partial image is a rendering");
    const ptext = await text(page, "#render-progress-text");
    assert.match(ptext, new RegExp(`^Job ${id} · running · \\d+(\\.\\d)?% done · pass \\d+: \\d+ samples per pixel · estimated error \\d+\\.\\d\\d of 255 levels · `), ptext);
    const bar = await page.evaluate(() => document.getElementById("render-bar").value);
    assert.ok(bar > 0 && bar < 1, `progress bar part way (${bar})`);
    const curve = await page.evaluate(() => {
      const svg = document.getElementById("curve");
      return { hidden: svg.hasAttribute("hidden") || getComputedStyle(svg).display === "none", circles: svg.querySelectorAll("circle").length, line: svg.querySelector("polyline")?.getAttribute("points") || "",
        height: svg.getBoundingClientRect().height, label: svg.getAttribute("aria-label") };
    });
    assert.equal(curve.hidden, false);
    assert.ok(curve.circles >= 2 && curve.line.split(" ").length === curve.circles, `one point a pass: ${JSON.stringify(curve)}`);
    assert.ok(curve.height > 50, `the curve is drawn (${curve.height} px high)`);
    assert.match(curve.label, /estimated error against time: \d+ passes, last \d+\.\d\d levels/);
    const pts = curve.line.split(" ").map((p) => p.split(",").map(Number));
    for (let k = 1; k < pts.length; k++) {
      assert.ok(pts[k][0] > pts[k - 1][0], "later passes to the right");
      assert.ok(pts[k][1] >= pts[k - 1][1], "the error goes down (SVG y grows downwards)");
    }
    await shot(page, "g1-render-running");

    await page.click("#cancel-btn");
    await page.waitForFunction(() => document.getElementById("render-msg").textContent === "Cancelled.", null, { timeout: STEP_MS });
    const st = await (await fetch(`${base}/v1/jobs/${id}`)).json();
    assert.equal(st.status, "cancelled", "the job ended cancelled");
    assert.ok(st.samples < 1024, `it stopped early (${st.samples} samples)`);
    assert.equal(await page.isEnabled("#render-btn"), true, "Render can be used again");
    assert.equal(await page.isEnabled("#cancel-btn"), false);
    assert.match(await text(page, "#render-stats"), /^Cancelled after \d/);
    assert.equal((await image(page, "render-img")).hidden, false, "the last pass stays on show");
    await shot(page, "g2-render-cancelled");
    // And it stays stopped.
    await sleep(1000);
    assert.equal((await (await fetch(`${base}/v1/jobs/${id}`)).json()).status, "cancelled");

    assert.deepEqual(log.errors, [], "no uncaught script errors");
    // A partial image asked for as the job ends may be refused (409).
    const others = consoleErrors(log).filter((t) => !/status of 409 .*partial=1/.test(t));
    assert.deepEqual(others, [], "no console errors");
  } finally {
    await context.close();
  }
});

test("(h) a render in passes that finishes: one curve point a pass, the final image, its stats", { timeout: TEST_MS }, async () => {
  const { context, page, log } = await openPage();
  try {
    await page.selectOption("#scene-pick", { label: "phong.cfg" });
    await page.waitForFunction(() => document.getElementById("scene-text").value.length > 0);
    await page.fill("#width", "160");
    await page.fill("#height", "120");
    await page.fill("#samples", "16");
    const posted = page.waitForResponse((r) => r.url().includes("/v1/jobs?") && r.request().method() === "POST");
    await renderAndWait(page);
    const id = (await (await posted).json()).id;
    assert.equal(await text(page, "#render-msg"), "Done.");
    const st = await (await fetch(`${base}/v1/jobs/${id}`)).json();
    assert.equal(st.status, "done");
    assert.equal(st.samples, 16);
    assert.ok(st.passes >= 3, `passes of 2, 2, 4, 8 (${st.passes})`);
    assert.equal(Number(await page.getAttribute("#curve", "data-points")), st.curve.length, "every pass on the curve");
    const stats = await text(page, "#render-stats");
    assert.match(stats, new RegExp(`^Rendered in \\d+ ms .*16 samples per pixel in ${st.passes} passes, estimated error \\d+\\.\\d\\d of 255 levels\\.$`), stats);
    const img = await imageLoaded(page, "render-img");
    assert.equal(img.naturalWidth, 160);
    assert.equal(await page.isVisible("#render-progress"), false, "progress hidden once done");
    await shot(page, "h1-render-passes-done");

    // Without passes: one pass, the scene's samples at once.
    await page.uncheck("#progressive");
    const posted2 = page.waitForResponse((r) => r.url().includes("/v1/jobs") && r.request().method() === "POST");
    await renderAndWait(page);
    const r2 = await posted2;
    assert.doesNotMatch(r2.url(), /time_budget_ms/);
    const st2 = await (await fetch(`${base}/v1/jobs/${(await r2.json()).id}`)).json();
    assert.equal(st2.passes, 1);
    assert.doesNotMatch(await text(page, "#render-stats"), /passes/);
    assert.deepEqual(log.errors, []);
    assert.deepEqual(consoleErrors(log), []);
  } finally {
    await context.close();
  }
});

// ---- faults the page once had ---------------------------------------------
// Each test below found a real fault of daemon/http/web/index.html; they now
// guard the fixes.

test("(f) a broken .grade file is listed greyed out with its error; the other assignments work", {
  timeout: TEST_MS,
}, async () => {
  const { context, page } = await openPage();
  try {
    const broken = page.locator("#assignment-pick option[value='zz_broken']");
    assert.equal(await broken.count(), 1, "the broken assignment is not listed");
    assert.equal(await broken.isDisabled(), true, "the broken assignment can be picked");
    const text = await broken.textContent();
    assert.match(text, /zz_broken\.grade:1:8: fail: expected a number/, text);
    assert.doesNotMatch(text, /\/tmp\//, "the page shows a server path");
    assert.notEqual(await page.inputValue("#assignment-pick"), "zz_broken");
    await page.selectOption("#assignment-pick", "phong");
    assert.match(await page.textContent("#assignment-info"), /Render it at 320×240/);
    await shot(page, "f-broken-assignment", false);
  } finally {
    await context.close();
  }
});

test("(regression) before the first render the Image panel shows no empty image box", {
  timeout: TEST_MS,
}, async () => {
  const { context, page } = await openPage();
  try {
    await shot(page, "x1-defect-empty-image-box", false);
    assert.equal(await page.getAttribute("#render-img", "src"), null);
    assert.equal(await page.isVisible("#render-img"), false, "an image with no picture is on show");
  } finally {
    await context.close();
  }
});

test("(regression) loading the page asks for no missing /favicon.ico", {
  timeout: TEST_MS,
}, async () => {
  const { context, page } = await openPage();
  try {
    const icon = await page.$("link[rel~='icon']");
    const status = (await fetch(base + "/favicon.ico")).status;
    assert.ok(icon !== null || status < 400, `no <link rel=icon> and GET /favicon.ico answers ${status}`);
  } finally {
    await context.close();
  }
});

test("(regression) the slider's thumb sits over the split it moves", {
  timeout: TEST_MS,
}, async () => {
  const { context, page } = await openPage();
  try {
    const resp = await gradeAndWait(page, "phong", files.fail);
    const v = await resp.json();
    await page.click("#tab-slider");
    await imageLoaded(page, "ref-img", v.reference_url);
    await page.locator("#slider").scrollIntoViewIfNeeded();
    const sb = await page.locator("#slider").boundingBox();
    const cb = await page.locator("#compare").boundingBox();
    for (const f of [0.2, 0.8]) {
      const x = sb.x + sb.width * f;
      await page.mouse.click(x, sb.y + sb.height / 2);
      await shot(page, `x3-defect-slider-at-${f * 100}`, false);
      const split = await page.locator("#compare-top").evaluate((e) => e.getBoundingClientRect().right);
      assert.ok(Math.abs(split - x) <= 12,
        `clicked the slider at x=${x.toFixed(0)}, the split is at x=${split.toFixed(0)} (images ${cb.x.toFixed(0)}..${(cb.x + cb.width).toFixed(0)}, slider ${sb.x.toFixed(0)}..${(sb.x + sb.width).toFixed(0)})`);
    }
  } finally {
    await context.close();
  }
});

test("(regression) a refused upload leaves no results of the previous grade on show", {
  timeout: TEST_MS,
}, async () => {
  const { context, page } = await openPage();
  try {
    await gradeAndWait(page, "phong", files.fail);
    await page.locator("#verdict").waitFor({ state: "visible" });
    const resp = await gradeAndWait(page, "phong", files.notPng);
    assert.equal(resp.status(), 415);
    await page.locator("#grade-panel").scrollIntoViewIfNeeded();
    await page.locator("#grade-panel").screenshot({ path: path.join(SHOTS, "x4-defect-stale-results.png") });
    assert.match(await text(page, "#grade-msg"), /not a PNG/);
    assert.equal(await page.isVisible("#metrics"), false, "the previous file's metrics are still shown");
    assert.equal(await page.isVisible("#grade-images"), false, "the previous file's heat map is still shown");
  } finally {
    await context.close();
  }
});

test("(regression) at phone width the grading form lines up with the other panels' contents", {
  timeout: TEST_MS,
}, async () => {
  const { context, page } = await openPage({ viewport: { width: 375, height: 740 }, deviceScaleFactor: 2, isMobile: true, hasTouch: true });
  try {
    const a = await box(page, "#scene-pick"), b = await box(page, "#assignment-pick");
    assert.ok(Math.abs(a.left - b.left) <= 1 && Math.abs(a.right - b.right) <= 1,
      `scene picker ${a.left}..${a.right}, assignment picker ${b.left}..${b.right}`);
  } finally {
    await context.close();
  }
});
