// Shared by the end-to-end tests: the server's URLs, launching Chromium, waiting for frames,
// image comparisons, and native reference renders.
//   DYNVIEW_BASE_URL   the server (web/ at /, scenes at /scenes/e2e/ and /scenes/corrupt/)
//   DYNVIEW_BIN        the dynview CLI, for native reference renders
//   DYNVIEW_E2E_SCENE  the e2e scene package folder (for the native render)
//   DYNVIEW_E2E_VIDEO_SCENE  the same package with video frames (served at /scenes/video/)
//   DYNVIEW_E2E_OUT    where screenshots go (target/e2e/)

import assert from "node:assert/strict";
import { execFileSync } from "node:child_process";
import fs from "node:fs";
import path from "node:path";
import { chromium } from "playwright-core";
import { PNG } from "pngjs";

export const BASE = process.env.DYNVIEW_BASE_URL || "http://127.0.0.1:8080/";
export const OUT = process.env.DYNVIEW_E2E_OUT || "../target/e2e";
export const SCENE_URL = process.env.DYNVIEW_SCENE_URL || `${BASE}?scene=scenes/e2e/`;
/** The page's render of a frame must match the native render of the exported camera path. */
export const MIN_PSNR_VS_NATIVE_DB = 40;

/** Headless Chromium (Debian's); `webgpu`: with WebGPU (SwiftShader) enabled. */
export function launch({ webgpu = false } = {}) {
  fs.mkdirSync(OUT, { recursive: true });
  const args = ["--no-sandbox", "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run"];
  // A page the test itself fulfils (the embedding page of another origin) has no address, so
  // Chromium's local network access checks would treat it as public and refuse its requests to
  // the server on 127.0.0.1; on the web, the embedding page and the viewer's host are both public.
  args.push("--disable-features=LocalNetworkAccessChecks");
  if (webgpu) args.push("--enable-unsafe-webgpu");
  return chromium.launch({ executablePath: process.env.CHROMIUM || "/usr/bin/chromium", args });
}

/** A page at `url`, collecting page errors and console errors. */
export async function openPage(browser, url = SCENE_URL) {
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  const errors = [];
  page.on("pageerror", (e) => errors.push(e.message));
  page.on("console", (m) => m.type() === "error" && errors.push(m.text()));
  await page.goto(url);
  return { page, errors };
}

export const firstFrame = (page) =>
  page.waitForFunction(() => window.dynview && window.dynview.state.framesDone > 0, null, { timeout: 90_000 });

/** Waits for a finished frame newer than `count` finished frames and returns its pixels. */
export async function nextDoneFrame(page, count) {
  await page.waitForFunction((n) => window.dynview.state.framesDone > n && !window.dynview.state.rendering, count, { timeout: 90_000 });
  return page.evaluate(() => window.dynview.lastImage());
}

export const framesDone = (page) => page.evaluate(() => window.dynview.state.framesDone);

/** Moves the time slider to `t` (as a user's drag ends) and waits for that step's finished
 * frame; returns its pixels unless `image` is false. */
export async function scrubTo(page, t, { image = true } = {}) {
  const n = await framesDone(page);
  await page.$eval(
    "#time",
    (el, value) => {
      el.value = String(value);
      el.dispatchEvent(new Event("input"));
      el.dispatchEvent(new Event("change"));
    },
    t,
  );
  await page.waitForFunction(
    ([count, want]) => window.dynview.state.framesDone > count && !window.dynview.state.rendering && window.dynview.state.timeStep === want,
    [n, t],
    { timeout: 120_000 },
  );
  return image ? page.evaluate(() => window.dynview.lastImage()) : null;
}

/** Steps playback forward `frames` times, each to a finished frame; returns the median wall and
 * solver time per frame (ms) and the frame size. */
export function stepForward(page, frames) {
  return page.evaluate(async (count) => {
    const d = window.dynview;
    const walls = [];
    const solver = [];
    for (let i = 0; i < count; i++) {
      const before = d.state.framesDone;
      const start = performance.now();
      document.getElementById("step-forward").click();
      while (d.state.framesDone === before || d.state.rendering) await new Promise((r) => setTimeout(r, 5));
      walls.push(performance.now() - start);
      solver.push(d.state.lastDone.elapsed_ms);
    }
    const median = (a) => [...a].sort((x, y) => x - y)[Math.floor(a.length / 2)];
    return { wall: median(walls), solver: median(solver), size: `${d.state.lastDone.width}x${d.state.lastDone.height}` };
  }, frames);
}

export function meanAbsDiff(a, b) {
  assert.equal(a.rgba.length, b.rgba.length);
  let sum = 0;
  for (let i = 0; i < a.rgba.length; i += 4) for (let c = 0; c < 3; c++) sum += Math.abs(a.rgba[i + c] - b.rgba[i + c]);
  return sum / ((a.rgba.length / 4) * 3);
}

export function psnr(a, b) {
  let se = 0;
  let n = 0;
  for (let i = 0; i < a.rgba.length; i += 4) {
    for (let c = 0; c < 3; c++) {
      const d = (a.rgba[i + c] - b.rgba[i + c]) / 255;
      se += d * d;
      n += 1;
    }
  }
  return se === 0 ? Infinity : 10 * Math.log10(n / se);
}

export function stddev(image) {
  const values = [];
  for (let i = 0; i < image.rgba.length; i += 4) values.push((image.rgba[i] + image.rgba[i + 1] + image.rgba[i + 2]) / 3);
  const mean = values.reduce((s, v) => s + v, 0) / values.length;
  return Math.sqrt(values.reduce((s, v) => s + (v - mean) ** 2, 0) / values.length);
}

/** The native CPU render (`dynview render`) of the page's current view as exported by it,
 * through the package folder `scene` (the e2e scene by default). */
export async function nativeRenderOfPage(page, scene = process.env.DYNVIEW_E2E_SCENE) {
  const json = await page.evaluate(() => window.dynview.cameraPathJson());
  const dir = fs.mkdtempSync(path.join(OUT, "native-"));
  try {
    fs.writeFileSync(path.join(dir, "camera_path.json"), json);
    execFileSync(process.env.DYNVIEW_BIN, ["render", "--scene", scene, "--path", path.join(dir, "camera_path.json"), "--out", path.join(dir, "out")]);
    const png = PNG.sync.read(fs.readFileSync(path.join(dir, "out", "00000.png")));
    return { width: png.width, height: png.height, rgba: Array.from(png.data) };
  } finally {
    fs.rmSync(dir, { recursive: true, force: true });
  }
}
