// End-to-end tests of the viewer page in headless Chromium (playwright-core driving Debian's
// /usr/bin/chromium), against the page and scenes served by `cargo xtask test`:
//   DYNVIEW_BASE_URL   the server (web/ at /, scenes at /scenes/e2e/ and /scenes/corrupt/)
//   DYNVIEW_BIN        the dynview CLI, for native reference renders
//   DYNVIEW_E2E_SCENE  the e2e scene package folder (for the native render)
//   DYNVIEW_E2E_OUT    where screenshots go (target/e2e/)
// The CPU path is tested: WebGPU is not enabled.

import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import { execFileSync } from "node:child_process";
import fs from "node:fs";
import path from "node:path";
import { chromium } from "playwright-core";
import { PNG } from "pngjs";

const BASE = process.env.DYNVIEW_BASE_URL || "http://127.0.0.1:8080/";
const OUT = process.env.DYNVIEW_E2E_OUT || "../target/e2e";
const SCENE_URL = process.env.DYNVIEW_SCENE_URL || `${BASE}?scene=scenes/e2e/`;
/** The page's render of a frame must match the native render of the exported camera path. */
const MIN_PSNR_VS_NATIVE_DB = 40;

let browser;
before(async () => {
  fs.mkdirSync(OUT, { recursive: true });
  browser = await chromium.launch({
    executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
    args: ["--no-sandbox", "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run"],
  });
});
after(async () => browser?.close());

async function openPage(url = SCENE_URL) {
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  const errors = [];
  page.on("pageerror", (e) => errors.push(e.message));
  page.on("console", (m) => m.type() === "error" && errors.push(m.text()));
  await page.goto(url);
  return { page, errors };
}

const firstFrame = (page) => page.waitForFunction(() => window.dynview && window.dynview.state.framesDone > 0, null, { timeout: 60_000 });

/** Waits for a finished frame newer than `count` finished frames and returns its pixels. */
async function nextDoneFrame(page, count) {
  await page.waitForFunction((n) => window.dynview.state.framesDone > n && !window.dynview.state.rendering, count, { timeout: 60_000 });
  return page.evaluate(() => window.dynview.lastImage());
}

const framesDone = (page) => page.evaluate(() => window.dynview.state.framesDone);

function meanAbsDiff(a, b) {
  assert.equal(a.rgba.length, b.rgba.length);
  let sum = 0;
  for (let i = 0; i < a.rgba.length; i += 4) for (let c = 0; c < 3; c++) sum += Math.abs(a.rgba[i + c] - b.rgba[i + c]);
  return sum / ((a.rgba.length / 4) * 3);
}

function psnr(a, b) {
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

function stddev(image) {
  const values = [];
  for (let i = 0; i < image.rgba.length; i += 4) values.push((image.rgba[i] + image.rgba[i + 1] + image.rgba[i + 2]) / 3);
  const mean = values.reduce((s, v) => s + v, 0) / values.length;
  return Math.sqrt(values.reduce((s, v) => s + (v - mean) ** 2, 0) / values.length);
}

test("opens the scene, shows a non-blank first frame equal to the native render", async () => {
  const { page, errors } = await openPage();
  const started = Date.now();
  await firstFrame(page);
  console.log(`first frame after ${Date.now() - started} ms`);
  await page.screenshot({ path: path.join(OUT, "01-first-frame.png") });
  // Full resolution, so the render can be compared pixel for pixel.
  let n = await framesDone(page);
  await page.selectOption("#scale", "1");
  const image = await nextDoneFrame(page, n);
  assert.ok(stddev(image) > 10, `the frame looks blank (std dev ${stddev(image)})`);

  const json = await page.evaluate(() => window.dynview.cameraPathJson());
  const dir = fs.mkdtempSync(path.join(OUT, "native-"));
  fs.writeFileSync(path.join(dir, "camera_path.json"), json);
  execFileSync(process.env.DYNVIEW_BIN, ["render", "--scene", process.env.DYNVIEW_E2E_SCENE, "--path", path.join(dir, "camera_path.json"), "--out", path.join(dir, "out")]);
  const png = PNG.sync.read(fs.readFileSync(path.join(dir, "out", "00000.png")));
  const native = { width: png.width, height: png.height, rgba: Array.from(png.data) };
  assert.equal(native.width, image.width);
  assert.equal(native.height, image.height);
  const db = psnr(image, native);
  console.log(`page vs native render: ${db.toFixed(1)} dB`);
  assert.ok(db > MIN_PSNR_VS_NATIVE_DB, `page render differs from the native render: ${db.toFixed(1)} dB`);
  fs.rmSync(dir, { recursive: true, force: true });
  await page.screenshot({ path: path.join(OUT, "02-full-resolution.png") });
  assert.deepEqual(errors, []);
  await page.close();
});

test("scrubbing the timeline changes the frame", async () => {
  const { page } = await openPage();
  await firstFrame(page);
  const before = await nextDoneFrame(page, 0);
  const n = await framesDone(page);
  await page.$eval("#time", (el) => {
    el.value = "3";
    el.dispatchEvent(new Event("input"));
    el.dispatchEvent(new Event("change"));
  });
  const after = await nextDoneFrame(page, n);
  assert.equal(await page.evaluate(() => window.dynview.state.timeStep), 3);
  assert.match(await page.textContent("#time-label"), /^4 \/ 4/);
  assert.ok(meanAbsDiff(before, after) > 0.5, `frame did not change (mean abs diff ${meanAbsDiff(before, after)})`);
  await page.screenshot({ path: path.join(OUT, "03-scrubbed.png") });
  await page.close();
});

test("dragging orbits the view, and reloading the URL with its hash restores view and time", async () => {
  const { page } = await openPage();
  await firstFrame(page);
  const before = await nextDoneFrame(page, 0);
  const viewBefore = await page.evaluate(() => window.dynview.state.view);
  const box = await page.locator("#view").boundingBox();
  const n = await framesDone(page);
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.down();
  for (let i = 1; i <= 10; i++) await page.mouse.move(box.x + box.width / 2 + 12 * i, box.y + box.height / 2 + 3 * i);
  await page.mouse.up();
  const after = await nextDoneFrame(page, n);
  const viewAfter = await page.evaluate(() => window.dynview.state.view);
  assert.notDeepEqual(viewAfter.eye, viewBefore.eye);
  assert.ok(meanAbsDiff(before, after) > 0.5, "the frame did not change after a drag");
  await page.screenshot({ path: path.join(OUT, "04-dragged.png") });

  await page.waitForFunction(() => location.hash.includes("eye="));
  const m = await framesDone(page);
  await page.$eval("#time", (el) => {
    el.value = "2";
    el.dispatchEvent(new Event("change"));
  });
  const original = await nextDoneFrame(page, m);
  await page.waitForFunction(() => location.hash.startsWith("#t=2&"));
  const url = page.url();
  const { page: reopened } = await openPage(url);
  await firstFrame(reopened);
  const restored = await nextDoneFrame(reopened, 0);
  const state = await reopened.evaluate(() => ({ view: window.dynview.state.view, t: window.dynview.state.timeStep }));
  assert.equal(state.t, 2);
  const viewNow = await page.evaluate(() => window.dynview.state.view);
  assert.deepEqual(state.view, viewNow, "the hash restores the view exactly");
  assert.equal(psnr(original, restored), Infinity, `reopened frame differs: ${psnr(original, restored).toFixed(1)} dB`);
  await reopened.screenshot({ path: path.join(OUT, "05-reopened-from-hash.png") });
  await reopened.close();
  await page.close();
});

test("a corrupted package shows an error naming the file", async () => {
  const { page } = await openPage(`${BASE}?scene=scenes/corrupt/`);
  const message = page.locator("#message");
  await message.waitFor({ state: "visible", timeout: 30_000 });
  const text = await message.textContent();
  assert.match(text, /Could not open the scene/);
  assert.match(text, /clouds\.bin/);
  await page.screenshot({ path: path.join(OUT, "06-corrupt-package.png") });
  const missing = await openPage(`${BASE}?scene=scenes/nothing-here/`);
  await missing.page.locator("#message").waitFor({ state: "visible", timeout: 30_000 });
  assert.match(await missing.page.textContent("#message"), /scene\.json: HTTP 404/);
  await missing.page.close();
  await page.close();
});

test("the page handles input while the worker renders", async () => {
  const { page } = await openPage();
  await firstFrame(page);
  await nextDoneFrame(page, 0);
  // A slow render: full resolution, most iterations.
  await page.selectOption("#quality", "best");
  await page.selectOption("#scale", "1");
  await page.waitForFunction(() => window.dynview.state.rendering);
  const viewBefore = await page.evaluate(() => window.dynview.state.view);
  // Input during the render: a key press moves the camera at once, and the main thread's
  // timers run on time.
  const probe = await page.evaluate(async () => {
    const rendering = window.dynview.state.rendering;
    const t0 = performance.now();
    await new Promise((r) => setTimeout(r, 0));
    return { rendering, timerMs: performance.now() - t0 };
  });
  await page.focus("#view");
  await page.keyboard.down("d");
  await page.waitForTimeout(100);
  await page.keyboard.up("d");
  const during = await page.evaluate(() => ({ view: window.dynview.state.view, rendering: window.dynview.state.rendering }));
  assert.ok(probe.rendering, "the worker was not rendering during the probe");
  assert.ok(probe.timerMs < 50, `a timer waited ${probe.timerMs.toFixed(1)} ms during a render`);
  assert.notDeepEqual(during.view.eye, viewBefore.eye, "the key press did not move the camera during the render");
  console.log(`timer latency during a render: ${probe.timerMs.toFixed(1)} ms`);
  await page.close();
});

test("keyframes export as a camera path, and the layout fits a phone", async () => {
  const context = await browser.newContext({ viewport: { width: 390, height: 844 }, isMobile: true, hasTouch: true, deviceScaleFactor: 2 });
  const page = await context.newPage();
  await page.goto(SCENE_URL);
  await firstFrame(page);
  await page.click("#key-add");
  await page.keyboard.press("2"); // snap to input camera 2
  await page.waitForFunction(() => location.hash.includes("eye="));
  await page.click("#key-add");
  assert.equal(await page.textContent("#key-count"), "2 keyframes");
  const json = JSON.parse(await page.evaluate(() => window.dynview.cameraPathJson()));
  assert.equal(json.camera_path.length, 2);
  assert.equal(json.camera_path[0].camera_to_world.length, 16);
  assert.notDeepEqual(json.camera_path[0].camera_to_world, json.camera_path[1].camera_to_world);
  // Nothing overflows the phone's width.
  const overflow = await page.evaluate(() => document.documentElement.scrollWidth - window.innerWidth);
  assert.ok(overflow <= 0, `the page is ${overflow} px wider than the phone`);
  await page.screenshot({ path: path.join(OUT, "07-phone.png"), fullPage: true });
  await context.close();
});

test("a keyframe path plays back and exports as a WebM video and a camera_path.json", async () => {
  const { page, errors } = await openPage();
  await firstFrame(page);
  await page.click("#key-add");
  await page.keyboard.press("3");
  await page.waitForFunction(() => window.dynview.state.view && !window.dynview.state.rendering);
  await page.$eval("#time", (el) => {
    el.value = "1";
    el.dispatchEvent(new Event("change"));
  });
  await page.click("#key-add");
  const pathDownload = page.waitForEvent("download");
  await page.click("#key-export");
  const pathFile = await (await pathDownload).path();
  const exported = JSON.parse(fs.readFileSync(pathFile, "utf8"));
  assert.equal(exported.camera_path.length, 2);
  assert.equal(exported.camera_path[1].render_time, 1 / 3);

  const videoDownload = page.waitForEvent("download", { timeout: 120_000 });
  await page.click("#video-export");
  const download = await videoDownload;
  assert.match(download.suggestedFilename(), /\.webm$/);
  const bytes = fs.readFileSync(await download.path());
  assert.ok(bytes.length > 1000, `video of ${bytes.length} bytes`);
  assert.deepEqual([...bytes.subarray(0, 4)], [0x1a, 0x45, 0xdf, 0xa3], "not a WebM (EBML) file");
  // The path played: the view ends at the last keyframe's time.
  assert.equal(await page.evaluate(() => window.dynview.state.timeStep), 1);
  assert.deepEqual(errors, []);
  await page.close();
});
