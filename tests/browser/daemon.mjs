// Starting and stopping `rayd serve` for a browser test, and the Chromium
// it is driven with. page.test.mjs keeps its own copy; class.test.mjs,
// code.test.mjs and verdict.test.mjs use these (several daemons: with and
// without --instructor-tokens, and one restarted on its own store).
import { spawn, execFileSync } from "node:child_process";
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { fileURLToPath } from "node:url";
import { chromium } from "playwright-core";

export const HERE = path.dirname(fileURLToPath(import.meta.url));
export const ROOT = path.resolve(HERE, "..", "..");
export const RAYD = path.resolve(process.cwd(), process.env.RAYD || path.join(ROOT, "build", "rayd"));
export const CHROMIUM = process.env.CHROMIUM || "/usr/bin/chromium";

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

const running = new Set();
function killAllNow() {
  for (const d of running) {
    if (d.proc.exitCode === null && d.proc.signalCode === null) {
      try { process.kill(d.proc.pid, "SIGKILL"); } catch { /* gone */ }
    }
  }
}
// Never leave a daemon behind, whatever ends this process.
process.on("exit", killAllNow);
for (const sig of ["SIGINT", "SIGTERM", "SIGHUP"]) {
  process.once(sig, () => { killAllNow(); process.exit(128 + os.constants.signals[sig]); });
}

// Whether this build of rayd serve knows a flag (from its --help).
export function serveHas(flag) {
  try {
    const out = execFileSync(RAYD, ["serve", "--help"], { encoding: "utf8", stdio: ["ignore", "pipe", "pipe"] });
    return out.includes(flag);
  } catch (e) {
    return String(e.stdout || "").includes(flag) || String(e.stderr || "").includes(flag);
  }
}

export function logTail(file, n = 20) {
  try {
    return fs.readFileSync(file, "utf8").trim().split("\n").slice(-n).join("\n");
  } catch {
    return "(no log)";
  }
}

// Starts `rayd serve` on a free loopback port in folder `dir` (port file,
// log, --data-dir; a folder used before is started again with its store);
// resolves once it listens.
export async function startDaemon(dir, args) {
  fs.mkdirSync(dir, { recursive: true });
  const portFile = path.join(dir, "port");
  const log = path.join(dir, "rayd-serve.log");
  fs.rmSync(portFile, { force: true }); // a restart in the same folder: not the last daemon's port
  const fd = fs.openSync(log, "w");
  const proc = spawn(RAYD, ["serve", "--listen", "127.0.0.1:0", "--port-file", portFile,
    "--data-dir", path.join(dir, "var"), ...args], { cwd: ROOT, stdio: ["ignore", "ignore", fd] });
  fs.closeSync(fd);
  const d = { proc, log, base: "" };
  running.add(d);
  const t0 = Date.now();
  let port = 0;
  while (!port) {
    if (proc.exitCode !== null || proc.signalCode !== null) {
      throw new Error(`rayd serve exited (${proc.exitCode ?? proc.signalCode}) before listening:\n${logTail(log)}`);
    }
    if (Date.now() - t0 > 30_000) {
      await stopDaemon(d);
      throw new Error(`rayd serve wrote no port file in 30 s:\n${logTail(log)}`);
    }
    try {
      const text = fs.readFileSync(portFile, "utf8");
      if (/^\d+\s*$/.test(text)) port = Number(text);
    } catch { /* not yet */ }
    if (!port) await sleep(50);
  }
  d.base = `http://127.0.0.1:${port}`;
  return d;
}

// SIGTERM, then SIGKILL after 15 s; resolves with how it ended.
export async function stopDaemon(d) {
  if (!d) return null;
  running.delete(d);
  const p = d.proc;
  if (p.exitCode !== null || p.signalCode !== null) return { code: p.exitCode, signal: p.signalCode };
  const exited = new Promise((r) => p.once("exit", (code, signal) => r({ code, signal })));
  process.kill(p.pid, "SIGTERM");
  let res = await Promise.race([exited, sleep(15_000).then(() => null)]);
  if (!res) {
    process.kill(p.pid, "SIGKILL");
    res = await Promise.race([exited, sleep(5_000).then(() => null)]);
    if (res) res.killed = true;
  }
  return res;
}

export function launchChromium() {
  // Chromium from Debian; playwright gives it a new empty profile of its own.
  return chromium.launch({
    executablePath: CHROMIUM,
    args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
      "--disable-background-networking", "--disable-component-update", "--disable-sync"],
    timeout: 60_000,
  });
}
