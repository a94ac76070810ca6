// Phones started by hand (`dynview synth --unsync`: a portrait phone with rotation metadata, a
// 60 fps phone and a variable-rate one among 30 fps ones), put on one timeline by `prep` from
// their sound: the package plays in the page as the native renderer renders it, and the
// portrait phone's view stands upright, as that phone filmed it.

import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import fs from "node:fs";
import path from "node:path";
import { PNG } from "pngjs";
import { BASE, OUT, MIN_PSNR_VS_NATIVE_DB, launch, openPage, firstFrame, scrubTo, framesDone, nextDoneFrame, psnr, nativeRenderOfPage } from "./helpers.mjs";

const PHONES = process.env.DYNVIEW_E2E_PHONES;
const PHONES_URL = `${BASE}?scene=scenes/phones/`;
const PORTRAIT = "cam03";

let browser;
before(async () => (browser = await launch()));
after(async () => browser?.close());

/** `png` resampled (nearest) to `width x height`, turned half a turn when `turned`. */
function resampled(png, width, height, turned = false) {
  const rgba = new Array(width * height * 4);
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) {
      let sx = Math.min(png.width - 1, Math.floor(((x + 0.5) * png.width) / width));
      let sy = Math.min(png.height - 1, Math.floor(((y + 0.5) * png.height) / height));
      if (turned) [sx, sy] = [png.width - 1 - sx, png.height - 1 - sy];
      for (let c = 0; c < 4; c++) rgba[(y * width + x) * 4 + c] = png.data[(sy * png.width + sx) * 4 + c];
    }
  }
  return { width, height, rgba };
}

test("a package from unsynchronized phones plays, the portrait phone's view upright", async () => {
  const report = JSON.parse(fs.readFileSync(path.join(PHONES, "prep", "report.json"), "utf8"));
  const timing = report.time_alignment;
  assert.equal(timing.method, "audio");
  const scene = path.join(PHONES, "prep", "scene");
  const manifest = JSON.parse(fs.readFileSync(path.join(scene, "scene.json"), "utf8"));
  const portraitIndex = manifest.cameras.findIndex((c) => c.name === PORTRAIT);
  const portrait = manifest.cameras[portraitIndex];
  assert.ok(portrait.height > portrait.width, `the portrait phone's frames stand upright: ${portrait.width}x${portrait.height}`);

  const { page, errors } = await openPage(browser, PHONES_URL);
  await firstFrame(page);
  // It plays: each step as the native renderer renders it.
  const last = timing.steps - 1;
  for (const t of [Math.floor(last / 2), last]) {
    const image = await scrubTo(page, t);
    const db = psnr(image, await nativeRenderOfPage(page, scene));
    console.log(`phones package, time step ${t}: page vs native render ${db.toFixed(1)} dB`);
    assert.ok(db > MIN_PSNR_VS_NATIVE_DB, `time step ${t}: the page's frame differs from the native render: ${db.toFixed(1)} dB`);
  }

  // From the portrait phone's viewpoint the page shows what that phone filmed then, upright.
  const n = await framesDone(page);
  await page.keyboard.press(String(portraitIndex + 1));
  const image = await nextDoneFrame(page, n);
  await page.screenshot({ path: path.join(OUT, "11-phones-portrait.png") });
  const t = await page.evaluate(() => window.dynview.state.timeStep);
  const clock = timing.cameras[PORTRAIT];
  const moment = clock.start_s + (clock.rate * t) / timing.fps;
  const filmed = JSON.parse(fs.readFileSync(path.join(PHONES, "truth", "unsync", `${PORTRAIT}.json`), "utf8")).video_times_s;
  const j = filmed.reduce((best, s, i) => (Math.abs(s - moment) < Math.abs(filmed[best] - moment) ? i : best), 0);
  const truth = PNG.sync.read(fs.readFileSync(path.join(PHONES, "truth", "input", PORTRAIT, `${String(j).padStart(5, "0")}.png`)));
  // The view keeps the phone's vertical field of view at the page's aspect: the phone's
  // picture is the band of the page's frame as wide as it, in the middle.
  const band = Math.round((portrait.width * image.height) / portrait.height);
  const left = Math.round((image.width - band) / 2);
  const shown = { width: band, height: image.height, rgba: [] };
  for (let y = 0; y < image.height; y++) shown.rgba.push(...image.rgba.slice((y * image.width + left) * 4, (y * image.width + left + band) * 4));
  const upright = psnr(shown, resampled(truth, band, image.height));
  const turned = psnr(shown, resampled(truth, band, image.height, true));
  console.log(`portrait phone at step ${t} (its frame ${j}; ${band}x${image.height} of ${image.width}x${image.height}): upright ${upright.toFixed(1)} dB, half a turn ${turned.toFixed(1)} dB`);
  assert.ok(upright > 20 && upright > turned + 5, `upright ${upright.toFixed(1)} dB, half a turn ${turned.toFixed(1)} dB`);
  assert.deepEqual(errors, []);
  await page.close();
});
