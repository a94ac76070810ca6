// Measures the viewer on a long video package (format v2) in headless Chromium (CPU path):
// time to the first frame and the bytes fetched for it, time to show a random frame after a
// scrub and the bytes fetched for it, and playback with decoding. Run by
// `cargo xtask bench-web --long-event`; prints a markdown table.
//   DYNVIEW_BASE_URL  the server with the long event at /scenes/long/
//   CHROMIUM          the browser (default /usr/bin/chromium)
//   SCRUBS            random scrubs timed (default 8)
//   FRAMES            frames of playback timed (default 20)

import { chromium } from "playwright-core";
import { scrubTo, stepForward } from "../e2e/helpers.mjs";

const BASE = process.env.DYNVIEW_BASE_URL || "http://127.0.0.1:8080/";
const SCRUBS = Number(process.env.SCRUBS || 8);
const FRAMES = Number(process.env.FRAMES || 20);

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
  args: ["--no-sandbox", "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run"],
});
const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
// Bytes of the package fetched (bodies of the responses under /scenes/), by file kind.
let fetched = { total: 0, video: 0, clouds: 0, other: 0, requests: 0 };
page.on("response", async (response) => {
  if (!response.url().includes("/scenes/")) return;
  const length = Number(response.headers()["content-length"] || 0);
  const kind = /\.ivf$/.test(response.url()) ? "video" : /clouds\.bin$/.test(response.url()) ? "clouds" : "other";
  fetched[kind] += length;
  fetched.total += length;
  fetched.requests += 1;
});
const reset = () => (fetched = { total: 0, video: 0, clouds: 0, other: 0, requests: 0 });
const idle = () => page.waitForFunction(() => !window.dynview.state.rendering, null, { timeout: 120_000 });

const t0 = Date.now();
await page.goto(`${BASE}?scene=scenes/long/`);
await page.waitForFunction(() => window.dynview && window.dynview.state.framesDone > 0, null, { timeout: 120_000 });
const firstFrameMs = Date.now() - t0;
const first = { ...fetched };
const info = await page.evaluate(() => window.dynview.state.info);
const steps = info.time_step_count;
await idle();

// Random scrubs: a time step drawn from the whole event (a fixed sequence, so runs compare).
let seed = 7;
const random = () => ((seed = (seed * 1103515245 + 12345) % 2 ** 31) / 2 ** 31);
const scrubs = [];
for (let i = 0; i < SCRUBS; i++) {
  const t = Math.floor(random() * steps);
  await idle();
  await new Promise((r) => setTimeout(r, 300)); // let prefetches settle
  reset();
  const start = Date.now();
  await scrubTo(page, t, { image: false });
  scrubs.push({ t, ms: Date.now() - start, bytes: fetched.total, video: fetched.video, requests: fetched.requests });
}

// Playback: step forward frame by frame; the wall time includes loading and decoding the step
// (the worker prefetches the next one while the page shows this one), the solver's time is the
// render alone.
await idle();
const play = await stepForward(page, FRAMES);
const desktopMemory = await page.evaluate(() => window.dynview.memory());

// A phone: a 390 px wide view gets the phone's budget of decoded steps; the same scrubs and
// playback, then the worker's memory (the wasm heap never shrinks: its size is the peak).
const phone = await browser.newPage({ viewport: { width: 390, height: 844 }, isMobile: true, hasTouch: true });
await phone.goto(`${BASE}?scene=scenes/long/`);
await phone.waitForFunction(() => window.dynview && window.dynview.state.framesDone > 0, null, { timeout: 120_000 });
seed = 7;
for (let i = 0; i < SCRUBS; i++) {
  await phone.waitForFunction(() => !window.dynview.state.rendering, null, { timeout: 120_000 });
  await scrubTo(phone, Math.floor(random() * steps), { image: false });
}
await stepForward(phone, FRAMES);
const phoneMemory = await phone.evaluate(() => window.dynview.memory());
const phoneSize = await phone.evaluate(() => `${window.dynview.state.lastDone.width}x${window.dynview.state.lastDone.height}`);
await browser.close();

const median = (a) => [...a].sort((x, y) => x - y)[Math.floor(a.length / 2)];
const kb = (b) => `${(b / 1024).toFixed(0)} KiB`;
console.log(`${info.name}: ${info.cameras.length} cameras, ${steps} time steps at ${info.fps} fps\n`);
console.log(`| measure | value |\n| --- | ---: |`);
console.log(`| time to first frame (navigation to the first finished frame, cold cache) | ${firstFrameMs} ms |`);
console.log(`| bytes fetched for it (requests) | ${kb(first.total)} (${first.requests}): video ${kb(first.video)}, clouds ${kb(first.clouds)}, scene.json and indexes ${kb(first.other)} |`);
console.log(`| random frame after a scrub, median of ${SCRUBS} (min..max) | ${median(scrubs.map((s) => s.ms))} ms (${Math.min(...scrubs.map((s) => s.ms))}..${Math.max(...scrubs.map((s) => s.ms))}) |`);
console.log(`| bytes fetched per scrub, median (video) | ${kb(median(scrubs.map((s) => s.bytes)))} (${kb(median(scrubs.map((s) => s.video)))}) |`);
console.log(`| playback ${play.size}: wall per frame incl. loading and decoding, median of ${FRAMES} | ${play.wall.toFixed(0)} ms (${(1000 / play.wall).toFixed(2)} frames/s) |`);
console.log(`| playback ${play.size}: the render alone (solver), median | ${play.solver.toFixed(0)} ms |`);
const mib = (b) => `${(b / 2 ** 20).toFixed(0)} MiB`;
console.log(`| worker memory after it all, 1280x800 view: wasm heap (decoded steps cached) | ${mib(desktopMemory.wasm_bytes)} (${mib(desktopMemory.cache_bytes)}) |`);
console.log(`| the same on a 390x844 phone view (frames ${phoneSize}): wasm heap (decoded steps cached) | ${mib(phoneMemory.wasm_bytes)} (${mib(phoneMemory.cache_bytes)}) |`);
console.log(`\nscrubs: ${scrubs.map((s) => `t=${s.t} ${s.ms} ms ${kb(s.bytes)}`).join("; ")}`);
