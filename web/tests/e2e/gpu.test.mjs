// End-to-end tests of the viewer's GPU path: headless Chromium with WebGPU enabled
// (SwiftShader, on the CPU: the page itself starts on the CPU, so the tests force the GPU). It cannot present WebGPU canvases, so the worker reads each
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

test("with a software WebGPU adapter (SwiftShader) the page starts on the CPU and says why", async () => {
  const { page, errors } = await openPage();
  await firstFrame(page);
  assert.equal(await renderer(page), "cpu");
  const text = await overlay(page);
  assert.match(text, /^CPU/);
  assert.match(text, /CPU \(wasm, worker\) chosen: the GPU \(.*swiftshader.*\) is a software adapter/i);
  assert.match(await page.$eval("#renderer", (el) => el.title), /software adapter/);
  const gpuOption = await page.$eval('#renderer option[value="gpu"]', (el) => ({ disabled: el.disabled, text: el.textContent }));
  assert.ok(!gpuOption.disabled, "the menu should still offer the software GPU");
  assert.match(gpuOption.text, /software/);
  assert.deepEqual(errors, []);
  await page.close();
});

test("timing a frame on each renderer keeps the faster (the CPU, against SwiftShader)", async () => {
  const { page, errors } = await openPage(`${SCENE_URL}&renderer-trial`);
  await firstFrame(page);
  assert.equal(await renderer(page), "cpu");
  const text = await overlay(page);
  const times = text.match(/CPU \(wasm, worker\) chosen: a 240x136 frame took (\d+) ms on the GPU and (\d+) ms on the CPU/);
  assert.ok(times, `the overlay does not give the trial's times: ${text}`);
  console.log(`renderer trial: GPU ${times[1]} ms, CPU ${times[2]} ms`);
  assert.ok(Number(times[2]) < Number(times[1]), "the slower renderer was kept");
  assert.deepEqual(errors, []);
  await page.close();
});

test("?renderer=gpu forces the GPU, equal to the native CPU render", async () => {
  const { page, errors } = await openPage(`${SCENE_URL}&renderer=gpu`);
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
  const { page } = await openPage(`${SCENE_URL}&renderer=gpu`);
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
