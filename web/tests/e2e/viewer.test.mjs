// End-to-end tests of the viewer page in headless Chromium (playwright-core driving Debian's
// /usr/bin/chromium), against the page and scenes served by `cargo xtask test` (see
// helpers.mjs for the environment). The CPU path is tested here: WebGPU is not enabled, so the
// page must choose the CPU; gpu.test.mjs tests the GPU path.

import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import fs from "node:fs";
import path from "node:path";
import {
  BASE,
  OUT,
  SCENE_URL,
  MIN_PSNR_VS_NATIVE_DB,
  launch,
  openPage as openIn,
  firstFrame,
  nextDoneFrame,
  framesDone,
  meanAbsDiff,
  psnr,
  stddev,
  nativeRenderOfPage,
} from "./helpers.mjs";

let browser;
before(async () => (browser = await launch()));
after(async () => browser?.close());

const openPage = (url) => openIn(browser, url);

test("opens the scene, shows a non-blank first frame equal to the native render", async () => {
  const { page, errors } = await openPage();
  const started = Date.now();
  await firstFrame(page);
  console.log(`first frame after ${Date.now() - started} ms`);
  // Without WebGPU the CPU renders, and the menu says the GPU is unavailable.
  assert.equal(await page.$eval("#renderer", (el) => el.value), "cpu");
  assert.match(await page.textContent("#overlay"), /^CPU/);
  assert.ok(await page.$eval('#renderer option[value="gpu"]', (el) => el.disabled));
  await page.screenshot({ path: path.join(OUT, "01-first-frame.png") });
  // Full resolution, so the render can be compared pixel for pixel.
  let n = await framesDone(page);
  await page.selectOption("#scale", "1");
  const image = await nextDoneFrame(page, n);
  assert.ok(stddev(image) > 10, `the frame looks blank (std dev ${stddev(image)})`);

  const native = await nativeRenderOfPage(page);
  assert.equal(native.width, image.width);
  assert.equal(native.height, image.height);
  const db = psnr(image, native);
  console.log(`page vs native render: ${db.toFixed(1)} dB`);
  assert.ok(db > MIN_PSNR_VS_NATIVE_DB, `page render differs from the native render: ${db.toFixed(1)} dB`);
  await page.screenshot({ path: path.join(OUT, "02-full-resolution.png") });
  assert.deepEqual(errors, []);
  await page.close();
});

test("asking for the GPU without WebGPU renders on the CPU and says why", async () => {
  const { page } = await openPage(`${SCENE_URL}&renderer=gpu`);
  await firstFrame(page);
  assert.equal(await page.$eval("#renderer", (el) => el.value), "cpu");
  const overlay = await page.textContent("#overlay");
  assert.match(overlay, /^CPU/);
  assert.match(overlay, /GPU unavailable \(.+\): rendering on the CPU/);
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

test("<dynview-viewer> embeds the viewer in a plain page of another origin, equal to the native render", async () => {
  // The host page is served (by the test) from localhost, the viewer from 127.0.0.1: two
  // origins, no cross-origin-isolation headers.
  const viewer = new URL(BASE);
  const host = new URL(BASE);
  host.hostname = "localhost";
  const hostPage = `${host.origin}/my-page.html`;
  const page = await browser.newPage({ viewport: { width: 900, height: 760 } });
  const errors = [];
  page.on("pageerror", (e) => errors.push(e.message));
  await page.route(hostPage, (route) =>
    route.fulfill({
      contentType: "text/html",
      body: `<!doctype html><html><head><meta charset="utf-8"><script type="module" src="${viewer.origin}/src/embed.js"></script></head>
        <body><h1>My page</h1><dynview-viewer src="${viewer.origin}/scenes/e2e/" style="width: 800px"></dynview-viewer></body></html>`,
    }),
  );
  await page.goto(hostPage);
  assert.equal(await page.evaluate(() => window.crossOriginIsolated), false);
  const frame = await (await page.waitForSelector("dynview-viewer iframe")).contentFrame();
  assert.ok(frame, "the element holds no frame");
  await firstFrame(frame);
  // The view and the timeline, without the app's bars.
  assert.ok(await frame.isVisible("#view"));
  assert.ok(await frame.isVisible("#timeline"));
  for (const bar of ["body > header.bar", "#controls", "#path", "#overlay"]) assert.ok(!(await frame.isVisible(bar)), `${bar} shows in the embed`);
  await page.screenshot({ path: path.join(OUT, "14-embedded.png") });
  // Full resolution (the scale menu is hidden: set it as the menu would), then the same
  // picture as the native render of the embed's view.
  const n = await framesDone(frame);
  await frame.$eval("#scale", (el) => {
    el.value = "1";
    el.dispatchEvent(new Event("change"));
  });
  const image = await nextDoneFrame(frame, n);
  const native = await nativeRenderOfPage(frame);
  const db = psnr(image, native);
  console.log(`embedded vs native render: ${db.toFixed(1)} dB`);
  assert.ok(db > MIN_PSNR_VS_NATIVE_DB, `the embedded frame differs from the native render: ${db.toFixed(1)} dB`);
  assert.deepEqual(errors, []);
  await page.close();
});
