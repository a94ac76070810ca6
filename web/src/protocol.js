// The messages between the page (client.js) and the renderer worker (worker.js): their type
// names, one constructor per message, and the few checks both sides make. Both sides import
// this module; neither writes a message by hand.
//
// Page -> worker:
//   {type: "canvas", canvas}                 the OffscreenCanvas the GPU path draws into (once,
//                                            before opening; transferred)
//   {type: "open", url, gpu, choose, trial}  open a scene package by URL
//   {type: "open-files", files, paths, gpu, choose, trial}
//                                            open a scene package from files (a chosen or
//                                            dropped folder); gpu: whether to set up the GPU
//                                            path; choose: whether to pick the renderer; trial:
//                                            time both even on a software GPU
//   {type: "render", request}                request: {id, renderer, view, time_step, width,
//                                            height, streaming, max_level, mode}; a newer
//                                            request replaces an older one
//   {type: "call", id, method, args}         a small query of the worker's Viewer (the
//                                            worker's `calls`), answered by "reply" or "error"
//   {type: "prefetch", time_step}            load a time step in the background
//
// Worker -> page:
//   {type: "opened", info, backends, gpu: {name, presents, software} | {error},
//    choice: {renderer, reason}}             the scene is open
//   {type: "frame", id, level, done, width, height, image, elapsed_ms, temporal_used, last}
//                                            a CPU frame (or one of its levels); image: ImageData
//   {type: "frame", id, gpu: true, level, done, width, height, elapsed_ms, ..., last: null}
//                                            a GPU frame (drawn into the canvas, or read back
//                                            as `image`)
//   {type: "progress", time_step, stats, done, total}
//                                            loading a time step
//   {type: "idle", last_id}                  no render request is left; last_id: the newest
//                                            request the worker had taken by then
//   {type: "gpu-lost", message}              the GPU path failed; the page falls back to the CPU
//   {type: "reply", id, value}               the value of a "call"
//   {type: "error", id, message, open}       a request failed; open: it was an opening

/** Types of the messages the page sends the worker. */
export const TO_WORKER = Object.freeze({
  CANVAS: "canvas",
  OPEN: "open",
  OPEN_FILES: "open-files",
  RENDER: "render",
  CALL: "call",
  PREFETCH: "prefetch",
});

/** Types of the messages the worker sends the page. */
export const FROM_WORKER = Object.freeze({
  OPENED: "opened",
  FRAME: "frame",
  PROGRESS: "progress",
  IDLE: "idle",
  GPU_LOST: "gpu-lost",
  REPLY: "reply",
  ERROR: "error",
});

const toWorkerTypes = new Set(Object.values(TO_WORKER));
const fromWorkerTypes = new Set(Object.values(FROM_WORKER));

/** Whether `msg` is a message the worker takes (an object with one of TO_WORKER's types). */
export function isToWorker(msg) {
  return typeof msg === "object" && msg !== null && toWorkerTypes.has(msg.type);
}

/** Whether `msg` is a message the page takes (an object with one of FROM_WORKER's types). */
export function isFromWorker(msg) {
  return typeof msg === "object" && msg !== null && fromWorkerTypes.has(msg.type);
}

/** Whether a message to the worker opens a scene (its failure rejects the opening). */
export function isOpening(msg) {
  return msg.type === TO_WORKER.OPEN || msg.type === TO_WORKER.OPEN_FILES;
}

/** The id of the request a message to the worker carries (a call's, or a render request's),
 * for the error that answers it; undefined when it has none. */
export function requestId(msg) {
  return msg.id ?? (msg.request && msg.request.id);
}

// ---- page -> worker ------------------------------------------------------------------------

/** Hands over the GPU path's OffscreenCanvas (to be transferred). */
export const canvasMessage = (canvas) => ({ type: TO_WORKER.CANVAS, canvas });

/** Opens a scene package by URL. */
export const openUrlMessage = (url, gpu = false, { choose = false, trial = false } = {}) =>
  ({ type: TO_WORKER.OPEN, url, gpu, choose, trial });

/** Opens a scene package from files and their paths inside the folder. */
export const openFilesMessage = (files, paths, gpu = false, { choose = false, trial = false } = {}) =>
  ({ type: TO_WORKER.OPEN_FILES, files, paths, gpu, choose, trial });

/** Asks for a frame: `request` with its `id`. */
export const renderMessage = (request, id) => ({ type: TO_WORKER.RENDER, request: { ...request, id } });

/** Calls the worker's query `method` with `args`; answered by a reply or an error of `id`. */
export const callMessage = (id, method, args) => ({ type: TO_WORKER.CALL, id, method, args });

/** Starts loading a time step in the background. */
export const prefetchMessage = (timeStep) => ({ type: TO_WORKER.PREFETCH, time_step: timeStep });

// ---- worker -> page ------------------------------------------------------------------------

/** The opened scene: its info, the renderers the worker has, the GPU's state and the choice. */
export const openedMessage = (info, backends, gpu, choice) => ({ type: FROM_WORKER.OPENED, info, backends, gpu, choice });

/** A CPU frame (or level) of request `id`: `report` is the viewer's step report, `image` its
 * picture, `last` the finished frame's timings (null before it is done). */
export const cpuFrameMessage = (id, report, image, last) => ({
  type: FROM_WORKER.FRAME,
  id,
  level: report.level,
  done: report.done,
  width: image.width,
  height: image.height,
  image,
  elapsed_ms: report.elapsed_ms,
  temporal_used: report.temporal_used,
  last,
});

/** A GPU frame of request `id`: the GPU render's report, as it is. */
export const gpuFrameMessage = (id, report) => ({ type: FROM_WORKER.FRAME, id, gpu: true, ...report, last: null });

/** Loading progress of time step `timeStep`: `done` of `total` frames, and the load stats. */
export const progressMessage = (timeStep, stats, done, total) => ({ type: FROM_WORKER.PROGRESS, time_step: timeStep, stats, done, total });

/** No render request is left; `lastId` is the id of the newest request the worker had taken. */
export const idleMessage = (lastId) => ({ type: FROM_WORKER.IDLE, last_id: lastId });

/**
 * Whether idle message `msg` means the page's newest request (`latestId`) is settled. An idle
 * posted before the worker took a request already on its way says nothing about that request.
 */
export const idleSettles = (msg, latestId) => msg.last_id >= latestId;

/** The GPU path failed with `message`. */
export const gpuLostMessage = (message) => ({ type: FROM_WORKER.GPU_LOST, message });

/** The value of call `id`. */
export const replyMessage = (id, value) => ({ type: FROM_WORKER.REPLY, id, value });

/** Request `id` failed with `message`; `open`: the failed request was an opening. */
export const errorMessage = (id, message, open = false) => ({ type: FROM_WORKER.ERROR, id, message, open });
