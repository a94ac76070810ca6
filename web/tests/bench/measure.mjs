// Measures the viewer in headless Chromium (CPU path, WebGPU off): time to first frame from
// navigation, and ms per frame of playback at each render scale. Run by `cargo xtask bench-web`
// against the demo event; prints a markdown table.
//   DYNVIEW_BASE_URL  the server with the demo event at /scenes/demo/
//   CHROMIUM          the browser (default /usr/bin/chromium)
//   FRAMES            frames of playback timed per scale (default 10)

import { chromium } from "playwright-core";
import { stepForward } from "../e2e/helpers.mjs";

const BASE = process.env.DYNVIEW_BASE_URL || "http://127.0.0.1:8080/";
const FRAMES = Number(process.env.FRAMES || 10);

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
  args: ["--no-sandbox", "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run"],
});
const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
const t0 = Date.now();
await page.goto(`${BASE}?scene=scenes/demo/`);
await page.waitForFunction(() => window.dynview && window.dynview.state.framesDone > 0, null, { timeout: 120_000 });
const firstFrameMs = Date.now() - t0;
const firstRender = await page.evaluate(() => window.dynview.state.lastDone.last);

const rows = [];
for (const scale of ["0.5", "1"]) {
  await page.selectOption("#scale", scale);
  await page.waitForFunction(() => !window.dynview.state.rendering, null, { timeout: 120_000 });
  // Warm the step cache so that decoding is not counted in the solver's time, then play.
  await page.evaluate(() => window.dynview.state.timeStep = 0);
  const play = await stepForward(page, FRAMES);
  const result = { size: play.size, solverMs: play.solver, wallMs: play.wall, last: await page.evaluate(() => window.dynview.state.lastDone.last) };
  rows.push(result);
}
await browser.close();

console.log(`| measure | value |\n| --- | ---: |`);
console.log(`| time to first frame (navigation to finished frame, 480x270) | ${firstFrameMs} ms |`);
console.log(`| first frame's render alone | ${firstRender.wall_ms.toFixed(0)} ms |`);
for (const r of rows) {
  console.log(`| CPU path ${r.size}, streaming playback: solver (median of ${FRAMES}) | ${r.solverMs.toFixed(0)} ms/frame |`);
  console.log(`| CPU path ${r.size}, streaming playback: wall incl. loading the step (median) | ${r.wallMs.toFixed(0)} ms/frame |`);
}
for (const r of rows) {
  const levels = r.last.timings.levels.map((l) => `L${l.level} ${l.width}x${l.height}: ${(l.warp_ms + l.visibility_ms).toFixed(0)} warp+vis, ${l.weights_ms.toFixed(0)} weights, ${l.depth_solve_ms.toFixed(0)} depth, ${l.color_solve_ms.toFixed(0)} color`);
  console.log(`\n${r.size} last frame per level (ms): ${levels.join("; ")}`);
}
