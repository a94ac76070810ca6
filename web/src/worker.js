// The renderer worker: owns the wasm Viewer, loads time steps, and renders frames on either
// path. CPU: one pyramid level at a time, yielding between levels so that a newer request (the
// user moved on) replaces the one in progress. GPU (WebGPU): the whole frame is submitted at
// once and drawn by the GPU straight into the page's canvas (an OffscreenCanvas handed over
// with "canvas"); the worker waits for the GPU without blocking and then takes the newest
// request. The page never waits on either.
//
// The messages in and out are protocol.js's.

import init, { Viewer } from "../pkg/dynview_web.js";
import {
  TO_WORKER,
  cpuFrameMessage,
  errorMessage,
  gpuFrameMessage,
  gpuLostMessage,
  idleMessage,
  isOpening,
  openedMessage,
  progressMessage,
  replyMessage,
  requestId,
} from "./protocol.js";
import { VideoFrames } from "./video.js";

let viewer = null;
let video = null; // the decoders of a video package's frames
let canvas = null; // the OffscreenCanvas of the GPU path
let pending = null; // the newest render request not yet started
let lastTakenId = 0; // the id of the newest render request received
let current = null; // the request whose job is in the viewer
let running = false;
const ready = init();

const post = (message, transfer) => self.postMessage(message, transfer || []);
const message = (e) => (e && e.message) || String(e);
const yieldToEvents = () => new Promise((resolve) => setTimeout(resolve, 0));

function sameFrame(a, b) {
  return (
    a && b && a.renderer === b.renderer && a.time_step === b.time_step && a.width === b.width && a.height === b.height &&
    a.streaming === b.streaming && JSON.stringify(a.view) === JSON.stringify(b.view)
  );
}

function postPicture(request, report) {
  const image = viewer.picture(request.mode || "color");
  post(cpuFrameMessage(request.id, report, image, report.done ? viewer.lastFrame() : null), [image.data.buffer]);
}

async function ensureLoaded(t) {
  if (viewer.isLoaded(t)) return;
  const progress = (stats, done, total) => post(progressMessage(t, stats, done, total));
  await (video ? video.load(t, progress) : viewer.loadStep(t, progress));
}

// Renders `request` on the GPU: submits it, waits (without blocking) until the GPU is done.
// A lost device or a GPU error is reported as "gpu-lost" (the page falls back to the CPU path);
// other errors (a bad request) as any error.
async function runGpu(request) {
  await ensureLoaded(request.time_step);
  if (pending) return;
  let report;
  try {
    report = await viewer.renderGpu(request);
  } catch (e) {
    // The browser reports a lost device asynchronously: give it a moment.
    const lost = viewer.gpuLost() || (await new Promise((resolve) => setTimeout(resolve, 100)), viewer.gpuLost());
    if (!lost) throw e;
    post(gpuLostMessage(lost));
    return;
  }
  post(gpuFrameMessage(request.id, report), report.image ? [report.image.data.buffer] : []);
}

// Renders `request` until it is done or reaches its `max_level` (a preview while the camera
// moves); returns early when a newer request arrives, unless that one is the same frame with
// more levels wanted, in which case the job simply goes on.
async function run(request) {
  await ensureLoaded(request.time_step);
  if (pending && !sameFrame(pending, request)) return;
  if (!(viewer.isRendering() && sameFrame(current, request))) {
    viewer.begin(request);
  }
  current = request;
  for (;;) {
    const report = viewer.step();
    postPicture(request, report);
    if (report.done) {
      current = null;
      return;
    }
    if (request.max_level != null && report.level <= request.max_level) return;
    await yieldToEvents();
    if (pending) {
      if (!sameFrame(pending, request)) return; // stale: the next run begins anew
      request = pending; // same frame, new wishes (finer levels, another id or mode)
      pending = null;
      current = request;
    }
  }
}

async function pump() {
  if (running) return;
  running = true;
  try {
    while (pending) {
      const request = pending;
      pending = null;
      try {
        await (request.renderer === "gpu" ? runGpu(request) : run(request));
      } catch (e) {
        current = null;
        post(errorMessage(request.id, message(e)));
      }
    }
  } finally {
    running = false;
    post(idleMessage(lastTakenId));
  }
}

const calls = {
  info: () => viewer.info(),
  inputView: (camera, t) => viewer.inputView(camera, t),
  setParams: (params) => viewer.setParams(params),
  params: () => viewer.params(),
  picture: (mode) => viewer.picture(mode),
  exportCameraPath: (keyframes, width, height, fps) => viewer.exportCameraPath(keyframes, width, height, fps),
  importCameraPath: (json, file) => viewer.importCameraPath(json, file),
  loadStats: () => viewer.loadStats(),
  memory: async () => ({ ...viewer.loadStats(), wasm_bytes: (await ready).memory.buffer.byteLength }),
  jump: () => viewer.jump(),
  setCacheBudget: (bytes) => viewer.setCacheBudget(bytes),
  gpuPicture: (mode) => viewer.gpuPicture(mode),
  loseGpu: () => viewer.loseGpu(),
};

// Whether this browser can present WebGPU canvases, tried on a throwaway device and canvas:
// headless Chromium on SwiftShader cannot (its first present loses the device), and a lost
// device cannot be revived. Resolves with `{presents, info, software}` (`info`: the
// adapter's; `software`: a CPU rasterizer such as SwiftShader, WebGPU's fallback adapter).
let presentProbe = null;
function probePresentation() {
  presentProbe ??= (async () => {
    const adapter = await navigator.gpu.requestAdapter();
    if (!adapter) return { presents: false, info: null, software: false };
    const software = isSoftware(adapter);
    const device = await adapter.requestDevice();
    let lost = false;
    device.lost.then(() => (lost = true));
    try {
      const context = new OffscreenCanvas(4, 4).getContext("webgpu");
      context.configure({ device, format: navigator.gpu.getPreferredCanvasFormat() });
      for (let i = 0; i < 2 && !lost; i++) {
        const encoder = device.createCommandEncoder();
        const view = context.getCurrentTexture().createView();
        encoder.beginRenderPass({ colorAttachments: [{ view, loadOp: "clear", storeOp: "store" }] }).end();
        device.queue.submit([encoder.finish()]);
        await Promise.race([device.queue.onSubmittedWorkDone(), device.lost]);
        await new Promise((resolve) => setTimeout(resolve, 50));
      }
    } catch {
      lost = true;
    }
    device.destroy();
    return { presents: !lost, info: adapter.info, software };
  })();
  return presentProbe;
}

// Whether `adapter` renders on the CPU: WebGPU's fallback adapter (`info.isFallbackAdapter`, or
// the adapter's own flag in older browsers), or a software rasterizer by name.
function isSoftware(adapter) {
  const info = adapter.info || {};
  const named = [info.vendor, info.architecture, info.description].filter(Boolean).join(" ");
  return Boolean(info.isFallbackAdapter ?? adapter.isFallbackAdapter) || /swiftshader|llvmpipe|lavapipe|software/i.test(named);
}

// Sets up the GPU path for the opened viewer: `{name, presents, software}` of the adapter
// (`presents`: frames are drawn into the page's canvas; else read back), or `{error}` saying
// why there is none.
async function enableGpu() {
  if (!navigator.gpu) return { error: "this browser has no WebGPU (navigator.gpu)" };
  try {
    const { presents, info, software } = await probePresentation();
    const target = presents ? canvas : null;
    if (target) {
      const first = viewer.info().cameras[0];
      target.width = first.width;
      target.height = first.height;
    }
    const described = await viewer.enableGpu(target);
    // Browsers often leave the adapter's description empty; vendor and architecture remain.
    const named = [info?.vendor, info?.architecture].filter(Boolean).join(" ");
    const name = [named, described].filter(Boolean).join(" ") || "adapter";
    return { name: software && !/software/i.test(name) ? `${name} (software)` : name, presents: Boolean(target), software };
  } catch (e) {
    return { error: message(e) };
  }
}

/** The size of the frame timed on each renderer when both are real. */
const TRIAL_SIZE = { width: 240, height: 136 };

// Picks the renderer to start on: `{renderer, reason}`. Never a software adapter over the CPU
// worker; when the GPU is a real one (or `trial` asks), one small frame of the start view is
// timed on each (the GPU twice: its first frame also builds pipelines and buffers) and the
// faster one is kept.
async function pickRenderer(gpu, trial) {
  if (!gpu.name) return { renderer: "cpu", reason: "" }; // the Renderer menu says why there is none
  if (gpu.software && !trial) return { renderer: "cpu", reason: `the GPU (${gpu.name}) is a software adapter, slower than the CPU worker` };
  const info = viewer.info();
  const t = info.start_time_step;
  await ensureLoaded(t);
  const request = { view: info.start_view, time_step: t, ...TRIAL_SIZE, streaming: false, mode: "color" };
  const time = async (render) => {
    const started = performance.now();
    await render();
    return performance.now() - started;
  };
  let gpuMs;
  try {
    gpuMs = await time(() => viewer.renderGpu(request));
    gpuMs = Math.min(gpuMs, await time(() => viewer.renderGpu(request)));
  } catch (e) {
    return { renderer: "cpu", reason: `a trial frame failed on the GPU (${message(e)})` };
  }
  const cpuMs = await time(async () => {
    viewer.begin(request);
    while (!viewer.step().done);
  });
  viewer.jump(); // the trial frames are no previous frame of anything
  const faster = gpuMs <= cpuMs ? "gpu" : "cpu";
  const size = `${TRIAL_SIZE.width}x${TRIAL_SIZE.height}`;
  return { renderer: faster, reason: `a ${size} frame took ${gpuMs.toFixed(0)} ms on the GPU and ${cpuMs.toFixed(0)} ms on the CPU` };
}

self.onmessage = async (event) => {
  const msg = event.data;
  try {
    await ready;
    if (msg.type === TO_WORKER.CANVAS) {
      canvas = msg.canvas;
    } else if (isOpening(msg)) {
      viewer = null;
      viewer = msg.type === TO_WORKER.OPEN ? await Viewer.openUrl(msg.url) : await Viewer.openFiles(msg.files, msg.paths);
      const info = viewer.info();
      video = info.video_codec ? new VideoFrames(viewer, info) : null;
      const gpu = msg.gpu ? await enableGpu() : { error: "not requested" };
      const choice = msg.choose ? await pickRenderer(gpu, Boolean(msg.trial)) : { renderer: null, reason: "" };
      post(openedMessage(viewer.info(), gpu.name ? ["cpu", "gpu"] : ["cpu"], gpu, choice));
    } else if (!viewer) {
      throw new Error("no scene is open");
    } else if (msg.type === TO_WORKER.RENDER) {
      if (viewer.isRendering() && !sameFrame(current, msg.request) && !running) viewer.cancel();
      pending = msg.request;
      lastTakenId = Math.max(lastTakenId, msg.request.id);
      pump();
    } else if (msg.type === TO_WORKER.PREFETCH) {
      if (!running) ensureLoaded(msg.time_step).catch(() => {});
    } else if (msg.type === TO_WORKER.CALL) {
      const value = await calls[msg.method](...(msg.args || []));
      const transfer = value instanceof ImageData ? [value.data.buffer] : [];
      post(replyMessage(msg.id, value), transfer);
    }
  } catch (e) {
    post(errorMessage(requestId(msg), message(e), isOpening(msg)));
  }
};
