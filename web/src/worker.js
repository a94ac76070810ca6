// The CPU renderer's worker: owns the wasm Viewer, loads time steps, renders one pyramid
// level at a time and yields between levels so that a newer request (the user moved on)
// replaces the one in progress. The page never waits on the solver.
//
// Messages in:  {type: "open", url} | {type: "open-files", files, paths}
//               | {type: "render", request}      request: {id, view, time_step, width, height,
//                                                 streaming, max_level, mode}
//               | {type: "call", id, method, args}   (small synchronous queries)
//               | {type: "prefetch", time_step}
// Messages out: {type: "opened", info, backends} | {type: "error", id, message}
//               | {type: "progress", time_step, stats, done, total}
//               | {type: "frame", id, level, done, image, elapsed_ms, temporal_used, last}
//               | {type: "reply", id, value} | {type: "idle"}

import init, { Viewer } from "../pkg/dynview_web.js";

let viewer = null;
let pending = null; // the newest render request not yet started
let current = null; // the request whose job is in the viewer
let running = false;
const ready = init();

const post = (message, transfer) => self.postMessage(message, transfer || []);
const message = (e) => (e && e.message) || String(e);
const yieldToEvents = () => new Promise((resolve) => setTimeout(resolve, 0));

function sameFrame(a, b) {
  return (
    a && b && a.time_step === b.time_step && a.width === b.width && a.height === b.height &&
    a.streaming === b.streaming && JSON.stringify(a.view) === JSON.stringify(b.view)
  );
}

function postPicture(request, report) {
  const image = viewer.picture(request.mode || "color");
  post(
    {
      type: "frame",
      id: request.id,
      level: report.level,
      done: report.done,
      width: image.width,
      height: image.height,
      image,
      elapsed_ms: report.elapsed_ms,
      temporal_used: report.temporal_used,
      last: report.done ? viewer.lastFrame() : null,
    },
    [image.data.buffer],
  );
}

async function ensureLoaded(t) {
  if (viewer.isLoaded(t)) return;
  await viewer.loadStep(t, (stats, done, total) => post({ type: "progress", time_step: t, stats, done, total }));
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
        await run(request);
      } catch (e) {
        current = null;
        post({ type: "error", id: request.id, message: message(e) });
      }
    }
  } finally {
    running = false;
    post({ type: "idle" });
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
  jump: () => viewer.jump(),
  setCacheBudget: (bytes) => viewer.setCacheBudget(bytes),
};

self.onmessage = async (event) => {
  const msg = event.data;
  try {
    await ready;
    if (msg.type === "open" || msg.type === "open-files") {
      viewer = null;
      viewer = msg.type === "open" ? await Viewer.openUrl(msg.url) : await Viewer.openFiles(msg.files, msg.paths);
      post({ type: "opened", info: viewer.info(), backends: ["cpu"] });
    } else if (!viewer) {
      throw new Error("no scene is open");
    } else if (msg.type === "render") {
      if (viewer.isRendering() && !sameFrame(current, msg.request) && !running) viewer.cancel();
      pending = msg.request;
      pump();
    } else if (msg.type === "prefetch") {
      if (!running) ensureLoaded(msg.time_step).catch(() => {});
    } else if (msg.type === "call") {
      const value = calls[msg.method](...(msg.args || []));
      const transfer = value instanceof ImageData ? [value.data.buffer] : [];
      post({ type: "reply", id: msg.id, value }, transfer);
    }
  } catch (e) {
    post({ type: "error", id: msg.id ?? (msg.request && msg.request.id), message: message(e), open: msg.type.startsWith("open") });
  }
};
