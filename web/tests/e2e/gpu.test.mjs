// End-to-end tests of the viewer's GPU path: headless Chromium with WebGPU enabled
// (SwiftShader, on the CPU). It cannot present WebGPU canvases, so the worker reads each
// frame's picture back; the render itself is the GPU's. See helpers.mjs for the environment.

import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import path from "node:path";
import { SCENE_URL, OUT, MIN_PSNR_VS_NATIVE_DB, launch, openPage as openIn, firstFrame, nextDoneFrame, framesDone, psnr, stddev, nativeRenderOfPage } from "./helpers.mjs";

let browser;
before(async () => (browser = await launch({ webgpu: true })));
after(async () => browser?.close());

const openPage = (url) => openIn(browser, url);
const overlay = (page) => page.textContent("#overlay");
const renderer = (page) => page.$eval("#renderer", (el) => el.value);

test("with WebGPU the page renders on the GPU, equal to the native CPU render", async () => {
  const { page, errors } = await openPage();
  const started = Date.now();
  await firstFrame(page);
  console.log(`GPU path: first frame after ${Date.now() - started} ms`);
  assert.equal(await renderer(page), "gpu");
  assert.match(await overlay(page), /^GPU \(WebGPU\)/);
  const n = await framesDone(page);
  await page.selectOption("#scale", "1");
  const image = await nextDoneFrame(page, n);
  assert.ok(stddev(image) > 10, `the frame looks blank (std dev ${stddev(image)})`);
  const native = await nativeRenderOfPage(page);
  assert.equal(image.width, native.width);
  assert.equal(image.height, native.height);
  const db = psnr(image, native);
  console.log(`page GPU vs native CPU render: ${db.toFixed(1)} dB; overlay: ${(await overlay(page)).split("\n")[0]}`);
  assert.ok(db > MIN_PSNR_VS_NATIVE_DB, `the GPU frame differs from the native render: ${db.toFixed(1)} dB`);
  await page.screenshot({ path: path.join(OUT, "10-gpu-frame.png") });
  assert.deepEqual(errors, []);
  await page.close();
});

test("?renderer=cpu starts on the CPU; the menu switches to the GPU and back, same picture", async () => {
  const { page, errors } = await openPage(`${SCENE_URL}&renderer=cpu`);
  await firstFrame(page);
  assert.equal(await renderer(page), "cpu");
  assert.match(await overlay(page), /^CPU/);
  let n = await framesDone(page);
  const cpu = await nextDoneFrame(page, n - 1);
  n = await framesDone(page);
  await page.selectOption("#renderer", "gpu");
  const gpu = await nextDoneFrame(page, n);
  assert.match(await overlay(page), /^GPU \(WebGPU\)/);
  const db = psnr(cpu, gpu);
  console.log(`page CPU vs page GPU: ${db.toFixed(1)} dB`);
  assert.ok(db > MIN_PSNR_VS_NATIVE_DB, `CPU and GPU frames differ: ${db.toFixed(1)} dB`);
  n = await framesDone(page);
  await page.selectOption("#renderer", "cpu");
  await nextDoneFrame(page, n);
  assert.match(await overlay(page), /^CPU/);
  assert.deepEqual(errors, []);
  await page.close();
});

test("a lost GPU device falls back to the CPU and says so in the overlay", async () => {
  const { page } = await openPage();
  await firstFrame(page);
  assert.equal(await renderer(page), "gpu");
  await page.evaluate(() => window.dynview.loseGpu());
  const n = await framesDone(page);
  await page.$eval("#time", (el) => {
    el.value = "2";
    el.dispatchEvent(new Event("change"));
  });
  const image = await nextDoneFrame(page, n);
  await page.waitForFunction(() => document.getElementById("overlay").textContent.includes("GPU lost"));
  const text = await overlay(page);
  assert.match(text, /^CPU/);
  assert.match(text, /GPU lost \(.*lost.*\): rendering on the CPU/);
  assert.equal(await renderer(page), "cpu");
  assert.ok(await page.$eval('#renderer option[value="gpu"]', (el) => el.disabled), "the menu still offers the lost GPU");
  assert.ok(stddev(image) > 10, "the CPU's frame after the loss looks blank");
  await page.screenshot({ path: path.join(OUT, "11-gpu-lost.png") });
  await page.close();
});
