// Browser test of the page's "Grade your code" panel: a student downloads
// the skeleton, uploads a correct PhongMaterial.h (PASS, the image and the
// lobe plot shown), one with a typical mistake (FAIL, the cause in words
// with an example), and one that does not compile (the error with its
// file, line and column). Skipped by a rayd whose sandbox cannot start.
// Screenshots: build/browser-screenshots/code/.
import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { ROOT, startDaemon, stopDaemon, logTail, launchChromium } from "./daemon.mjs";

const SHOTS = path.join(ROOT, "build", "browser-screenshots", "code");
const GRADE_MS = 90_000;
const STUDENTS = path.join(ROOT, "tests", "codegrade", "students");

let tmp, d, browser, sandboxOk = false;

before(async () => {
  fs.mkdirSync(SHOTS, { recursive: true });
  tmp = fs.mkdtempSync(path.join(os.tmpdir(), "rayd-code-page-"));
  d = await startDaemon(path.join(tmp, "d"), []);
  sandboxOk = !/code grading is off/.test(fs.readFileSync(d.log, "utf8"));
  browser = await launchChromium();
});

after(async () => {
  if (browser) await browser.close();
  await stopDaemon(d);
  if (tmp) fs.rmSync(tmp, { recursive: true, force: true });
});

// The file a student would upload, under the name the course gives it.
function upload(fixture, name, edit) {
  let text = fs.readFileSync(path.join(STUDENTS, fixture), "utf8");
  if (edit) text = edit(text);
  const file = path.join(tmp, name);
  fs.writeFileSync(file, text);
  return file;
}

async function gradeIn(page, file) {
  await page.selectOption("#code-assignment", "phong");
  await page.setInputFiles("#code-file", file);
  await page.click("#code-btn");
  await page.waitForSelector("#code-verdict:not([hidden])", { timeout: GRADE_MS });
}

test("grade your code: pass, a named mistake, a compile error", { timeout: 4 * GRADE_MS }, async (t) => {
  if (!sandboxOk) {
    t.skip("this machine's sandbox cannot start: " + logTail(d.log, 3));
    return;
  }
  const page = await browser.newPage({ viewport: { width: 1280, height: 1000 } });
  const errors = [];
  page.on("pageerror", (e) => errors.push(String(e)));
  await page.goto(d.base + "/");
  await page.waitForSelector("#code-assignment option[value=phong]", { state: "attached", timeout: 20_000 });

  // The skeleton link serves the course's header.
  const skeleton = await page.evaluate(async () => (await fetch(
    document.querySelector('a[href="/v1/grade/code/skeleton/phong"]').href)).text());
  assert.match(skeleton, /class PhongMaterial/);

  await gradeIn(page, upload("phong_ok.h", "PhongMaterial.h"));
  assert.match(await page.textContent("#code-verdict"), /^PASS/);
  await page.waitForFunction(() => {
    const i = document.getElementById("code-diff"), l = document.getElementById("code-lobe");
    return i.complete && i.naturalWidth === 320 && l.complete && l.naturalWidth > 0;
  }, null, { timeout: 20_000 });
  assert.match(await page.textContent("#code-image-verdict"), /The image passes: .* from \d+ calls of your function/);
  assert.match(await page.getAttribute("#code-image-link", "href"), /^\/v1\/grades\/g[0-9a-f]+\/image\.png$/);
  await page.screenshot({ path: path.join(SHOTS, "1-pass.png"), fullPage: true });

  await gradeIn(page, upload("phong_missing_max.h", "PhongMaterial.h"));
  assert.match(await page.textContent("#code-verdict"), /^FAIL/);
  assert.equal(await page.isVisible("#code-causes"), true);
  const cause = await page.textContent("#code-cause-list li");
  assert.match(cause, /missing_max/);
  assert.match(cause, /For example \(\w+\): N = \(/);
  await page.screenshot({ path: path.join(SHOTS, "2-mistake.png"), fullPage: true });

  await gradeIn(page, upload("phong_ok.h", "PhongMaterial.h", (s) => s.replace("return diffuse + specular;", "return diffuse +;")));
  assert.match(await page.textContent("#code-verdict"), /does not compile/);
  assert.match(await page.textContent("#code-msg"), /^the code does not compile: PhongMaterial\.h:\d+:\d+: /);
  const diag = await page.textContent("#code-diags li.error");
  assert.match(diag, /^PhongMaterial\.h:\d+:\d+: error: /);
  assert.doesNotMatch(await page.textContent("#code-messages"), /\/work\/|\/rayd\//);
  assert.equal(await page.isVisible("#code-images"), false);
  await page.screenshot({ path: path.join(SHOTS, "3-compile-error.png"), fullPage: true });
  assert.deepEqual(errors, []);
  await page.close();
});
