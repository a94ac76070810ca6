// A video package (format v2: one VP9 stream per camera, decoded in the worker with WebCodecs):
// scrubbing to arbitrary frames, across keyframe groups and backwards, shows exactly what the
// native render of that time shows, and only the byte ranges it needs are fetched.

import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import path from "node:path";
import { BASE, OUT, MIN_PSNR_VS_NATIVE_DB, launch, openPage, firstFrame, scrubTo, psnr, nativeRenderOfPage } from "./helpers.mjs";

const VIDEO_URL = `${BASE}?scene=scenes/video/`;

let browser;
before(async () => (browser = await launch()));
after(async () => browser?.close());

test("scrubbing a video package shows exactly the frame the native render shows", async () => {
  const { page, errors } = await openPage(browser, VIDEO_URL);
  const ranges = [];
  page.on("request", (r) => r.url().endsWith(".ivf") && ranges.push(r.headers().range));
  await firstFrame(page);
  // Keyframes every 3 frames: 3 starts a group, 2 ends the first, then back to 0 and on to 1.
  for (const t of [3, 2, 0, 1]) {
    const image = await scrubTo(page, t);
    const native = await nativeRenderOfPage(page, process.env.DYNVIEW_E2E_VIDEO_SCENE);
    const db = psnr(image, native);
    console.log(`video package, time step ${t}: page vs native render ${db.toFixed(1)} dB`);
    assert.ok(db > MIN_PSNR_VS_NATIVE_DB, `time step ${t}: the page's frame differs from the native render: ${db.toFixed(1)} dB`);
  }
  await page.screenshot({ path: path.join(OUT, "10-video-package.png") });
  // Every video read is a byte range, never a whole file.
  assert.ok(ranges.length > 0 && ranges.every((r) => /^bytes=\d+-\d+$/.test(r || "")), `video reads: ${ranges}`);
  assert.deepEqual(errors, []);
  await page.close();
});
