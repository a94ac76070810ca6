// The viewer page: wires the controls, the timeline and the keyframe tools to the renderer
// worker, and shows its frames. All rendering happens in the worker (see client.js): CPU
// frames arrive as pictures drawn into #view; GPU frames are drawn by the worker into
// #view-gpu (an OffscreenCanvas), which then covers #view.

import { RendererClient, RENDERERS, chooseRenderer } from "./client.js";
import { ViewControls } from "./controls.js";
import { filesFromDrop, filesFromInput } from "./files.js";
import { decodeHash, encodeHash } from "./hash.js";
import { KeyframeTrack, playbackFrames } from "./keyframes.js";

const $ = (id) => document.getElementById(id);
const canvas = $("view");
const ctx = canvas.getContext("2d");
const scratch = document.createElement("canvas");
const gpuCanvas = $("view-gpu");
/** `?embed`: inside a `<dynview-viewer>` element (src/embed.js): the view and the timeline only. */
if (new URLSearchParams(location.search).has("embed")) document.body.classList.add("embed");
/** `?renderer=cpu|gpu` forces a renderer (when it is available). */
const forcedRenderer = new URLSearchParams(location.search).get("renderer");

/** Iteration presets of the quality control (fields of dynview-core's RenderParams). */
const QUALITY = {
  fast: { outer_iterations: 1, outer_iterations_finest: 1, depth_sweeps: 12, color_sweeps: 6 },
  balanced: {},
  best: { outer_iterations: 3, outer_iterations_finest: 2, depth_sweeps: 32, color_sweeps: 16 },
};
/** Coarsest levels shown while the view moves (levels >= this are rendered, then it waits). */
const MOVING_MAX_LEVEL = 2;
/** How long the view must rest before the full frame is rendered. */
const REST_MS = 120;

const state = {
  info: null,
  view: null,
  timeStep: 0,
  playing: false,
  renderer: "cpu",
  gpu: null, // {name} of the adapter, or {error}
  gpuNote: "", // why the GPU path is not in use, shown in the overlay
  choice: null, // {renderer, reason}: the worker's pick at start
  latestId: 0,
  shownId: 0,
  rendering: false,
  framesDone: 0,
  lastDone: null, // {image, width, height, elapsed_ms, id, time_step}
  lastShownAt: 0,
  playbackTimer: 0,
  path: null, // frames being played back
  pathIndex: 0,
  recorder: null,
};
const track = new KeyframeTrack();
let restTimer = 0;
let hashTimer = 0;
let firstFrame;
const firstFrameShown = new Promise((resolve) => (firstFrame = resolve));

const client = new RendererClient({ onFrame, onProgress, onError: showError, onIdle: () => (state.rendering = false), onGpuLost });
/** Whether to set up the GPU path (also when the URL starts on the CPU: the menu can switch). */
const gpuWanted = "gpu" in navigator && "transferControlToOffscreen" in gpuCanvas;
if (gpuWanted) client.setCanvas(gpuCanvas.transferControlToOffscreen());
/** How the worker picks the renderer: unless the URL forces one; `?renderer-trial` times both
 * even on a software GPU (tests). */
const choosing = { choose: gpuWanted && !forcedRenderer, trial: new URLSearchParams(location.search).has("renderer-trial") };
const controls = new ViewControls(canvas, {
  onChange: (view) => {
    state.view = view;
    stopPlayback();
    requestFrame({ moving: true });
    saveHashSoon();
  },
  onInteractionEnd: () => requestFrame({ moving: false }),
});

// ---- rendering -------------------------------------------------------------------------

function renderSize() {
  const cam = state.info.cameras[0];
  const scale = Number($("scale").value);
  return { width: Math.max(16, Math.round(cam.width * scale)), height: Math.max(9, Math.round(cam.height * scale)) };
}

/**
 * Asks the worker for the current view and time. While the view moves only the coarse levels
 * are rendered; once it rests for REST_MS the same frame is refined to full resolution.
 */
function requestFrame({ moving = false, streaming = false } = {}) {
  if (!state.info) return;
  const { width, height } = renderSize();
  const request = {
    renderer: state.renderer,
    view: state.view,
    time_step: state.timeStep,
    width,
    height,
    streaming,
    mode: $("display").value,
    max_level: moving ? MOVING_MAX_LEVEL : null,
  };
  state.rendering = true;
  state.latestId = client.render(request);
  clearTimeout(restTimer);
  if (moving) restTimer = setTimeout(() => !controls.interacting && requestFrame({ streaming }), REST_MS);
  return state.latestId;
}

function onFrame(msg) {
  if (msg.id < state.shownId) return; // an older request finishing late
  state.shownId = msg.id;
  hide("loading");
  hide("message");
  if (!msg.image) {
    gpuCanvas.hidden = false; // the GPU has drawn it already
  } else {
    gpuCanvas.hidden = true;
    scratch.width = msg.width;
    scratch.height = msg.height;
    scratch.getContext("2d").putImageData(msg.image, 0, 0);
    ctx.imageSmoothingEnabled = true;
    ctx.imageSmoothingQuality = "high";
    ctx.drawImage(scratch, 0, 0, canvas.width, canvas.height);
  }
  if (state.recorder) state.recorder.track.requestFrame?.();
  const { width, height } = renderSize();
  const label = msg.gpu ? `${RENDERERS.gpu} ${state.gpu.name}${state.gpu.presents ? "" : ", read back"}` : RENDERERS.cpu;
  const lines = [
    `${label}  ${msg.width}x${msg.height}${msg.done ? "" : msg.gpu ? "  preview" : `  level ${msg.level}`}`,
    `${msg.done ? "frame" : "so far"} ${msg.elapsed_ms.toFixed(0)} ms  target ${width}x${height}`,
    `t ${state.timeStep + 1}/${state.info.time_step_count}${msg.done && msg.temporal_used ? "  temporal" : ""}`,
  ];
  if (state.gpuNote) lines.push(state.gpuNote);
  $("overlay").textContent = lines.join("\n");
  if (!msg.done) return;
  state.framesDone += 1;
  state.lastDone = {
    id: msg.id,
    gpu: Boolean(msg.gpu),
    image: msg.image,
    width: msg.width,
    height: msg.height,
    elapsed_ms: msg.elapsed_ms,
    time_step: state.timeStep,
    last: msg.last,
  };
  if (msg.id === state.latestId) state.rendering = false;
  firstFrame();
  advancePlayback();
}

/** The GPU path failed (device lost, GPU error): the CPU path takes over, and says so. */
function onGpuLost(message) {
  state.gpuNote = `GPU lost (${message}): rendering on the CPU`;
  state.gpu = { error: message };
  const option = [...$("renderer").options].find((o) => o.value === "gpu");
  if (option) {
    option.disabled = true;
    option.textContent = `${RENDERERS.gpu}: lost`;
  }
  state.renderer = "cpu";
  $("renderer").value = "cpu";
  gpuCanvas.hidden = true;
  requestFrame();
}

function onProgress(msg) {
  const el = $("loading");
  el.hidden = false;
  const mb = (msg.stats.bytes_read / 1e6).toFixed(1);
  el.querySelector(".loading-text").textContent =
    `Loading time step ${msg.time_step + 1}: ${msg.done}/${msg.total} frames, ${mb} MB read, ${msg.stats.frames_read} frames in all`;
  el.querySelector(".progress-fill").style.width = `${(100 * msg.done) / Math.max(1, msg.total)}%`;
}

// ---- time and playback -----------------------------------------------------------------

function setTime(t, { streaming = false, moving = false } = {}) {
  const count = state.info.time_step_count;
  state.timeStep = Math.min(Math.max(0, t), count - 1);
  $("time").value = String(state.timeStep);
  const seconds = state.timeStep / state.info.fps;
  $("time-label").textContent = `${state.timeStep + 1} / ${count}  ${seconds.toFixed(2)} s`;
  saveHashSoon();
  requestFrame({ streaming, moving });
}

function togglePlay() {
  state.playing ? stopPlayback() : startPlayback();
}

function startPlayback() {
  state.path = null;
  state.playing = true;
  $("play").innerHTML = "&#10074;&#10074;";
  $("play").setAttribute("aria-label", "Pause");
  const next = state.timeStep + 1 >= state.info.time_step_count ? 0 : state.timeStep + 1;
  setTime(next, { streaming: next !== 0 });
}

function stopPlayback() {
  if (!state.playing && !state.path) return;
  state.playing = false;
  state.path = null;
  clearTimeout(state.playbackTimer);
  $("play").innerHTML = "&#9654;";
  $("play").setAttribute("aria-label", "Play");
  if (state.recorder) finishVideo();
}

/** After a finished frame: the next frame of the playback or of the keyframe path. */
function advancePlayback() {
  const interval = 1000 / (state.info.fps * Number($("speed").value));
  const wait = Math.max(0, interval - (performance.now() - state.lastShownAt));
  state.lastShownAt = performance.now();
  if (state.path) {
    state.pathIndex += 1;
    if (state.pathIndex >= state.path.length) return stopPlayback();
    state.playbackTimer = setTimeout(() => showPathFrame(true), wait);
  } else if (state.playing) {
    const next = state.timeStep + 1;
    if (next >= state.info.time_step_count) return stopPlayback();
    if (next + 1 < state.info.time_step_count) client.prefetch(next + 1);
    state.playbackTimer = setTimeout(() => state.playing && setTime(next, { streaming: true }), wait);
  }
}

function showPathFrame(streaming) {
  const frame = state.path[state.pathIndex];
  state.view = frame.view;
  controls.setView(frame.view);
  setTime(frame.time_step, { streaming });
}

function playPath() {
  if (track.length === 0) return showError("Record at least one keyframe (+ Keyframe or K) first.");
  stopPlayback();
  state.path = playbackFrames(track, state.info.fps, 2);
  state.pathIndex = 0;
  showPathFrame(false);
}

// ---- keyframes and export --------------------------------------------------------------

function download(blob, name) {
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob);
  a.download = name;
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 10_000);
}

function updateKeyCount() {
  $("key-count").textContent = `${track.length} keyframe${track.length === 1 ? "" : "s"}`;
}

/** The keyframes (or the current view alone) as a nerfstudio camera_path.json string. */
async function cameraPathJson() {
  const keyframes = track.length ? track.keyframes : [{ view: state.view, time_step: state.timeStep }];
  const { width, height } = renderSize();
  return client.call("exportCameraPath", keyframes, width, height, state.info.fps);
}

async function importPath(file) {
  const frames = await client.call("importCameraPath", await file.text(), file.name);
  track.clear();
  for (const f of frames) track.add(f.view, f.time_step);
  updateKeyCount();
}

function exportVideo() {
  if (track.length === 0) return showError("Record keyframes first: the video plays the keyframe path.");
  if (typeof MediaRecorder === "undefined") return showError("This browser cannot record video (no MediaRecorder).");
  const stream = (gpuCanvas.hidden ? canvas : gpuCanvas).captureStream(0);
  const mime = ["video/webm;codecs=vp9", "video/webm;codecs=vp8", "video/webm"].find((m) => MediaRecorder.isTypeSupported(m));
  const recorder = new MediaRecorder(stream, mime ? { mimeType: mime } : undefined);
  const chunks = [];
  recorder.ondataavailable = (e) => e.data.size && chunks.push(e.data);
  recorder.onstop = () => download(new Blob(chunks, { type: "video/webm" }), `${state.info.name}.webm`);
  state.recorder = { recorder, track: stream.getVideoTracks()[0] };
  recorder.start();
  playPath();
}

function finishVideo() {
  const { recorder } = state.recorder;
  state.recorder = null;
  recorder.stop();
}

// ---- view helpers ----------------------------------------------------------------------

async function snapToCamera(index) {
  if (!state.info || index >= state.info.cameras.length) return;
  const view = await client.call("inputView", index, state.timeStep);
  state.view = view;
  controls.setView(view);
  saveHashSoon();
  requestFrame();
}

function resetView() {
  state.view = state.info.start_view;
  controls.setView(state.view);
  saveHashSoon();
  requestFrame();
}

function saveHashSoon() {
  clearTimeout(hashTimer);
  hashTimer = setTimeout(() => state.view && history.replaceState(null, "", encodeHash(state.view, state.timeStep)), 150);
}

// ---- messages ----------------------------------------------------------------------------

function hide(id) {
  $(id).hidden = true;
}

function showError(message) {
  const el = $("message");
  el.textContent = message;
  el.hidden = false;
  hide("loading");
  state.rendering = false;
}

// ---- opening -----------------------------------------------------------------------------

/** Views at most this wide are a phone's: they get the phone's memory budget. */
const PHONE_MAX_WIDTH_PX = 600;
/** Decoded time steps a phone keeps (about one step of six 960x540 cameras; 256 MiB elsewhere). */
const PHONE_CACHE_BUDGET_BYTES = 64 << 20;

async function open(opening, label) {
  stopPlayback();
  hide("landing");
  hide("message");
  const loading = $("loading");
  loading.hidden = false;
  loading.querySelector(".loading-text").textContent = `Opening ${label}…`;
  loading.querySelector(".progress-fill").style.width = "0%";
  try {
    const { info, backends, gpu, choice } = await opening;
    state.info = info;
    state.gpu = gpu;
    // A phone keeps fewer decoded steps (the newest is always kept).
    if (window.innerWidth <= PHONE_MAX_WIDTH_PX) client.call("setCacheBudget", PHONE_CACHE_BUDGET_BYTES);
    state.choice = choice;
    setupScene(info, backends);
  } catch (e) {
    state.info = null;
    showError(`Could not open the scene ${label}:\n${e.message}`);
  }
}

function setupScene(info, backends) {
  $("scene-name").textContent = `${info.name} · ${info.cameras.length} cameras · ${info.time_step_count} frames`;
  const first = info.cameras[0];
  canvas.width = first.width;
  canvas.height = first.height;
  $("viewport").style.aspectRatio = `${first.width} / ${first.height}`;
  $("time").max = String(info.time_step_count - 1);
  const buttons = $("camera-buttons");
  buttons.replaceChildren(
    ...info.cameras.map((cam, i) => {
      const b = document.createElement("button");
      b.textContent = String(i + 1);
      b.title = `Snap to input camera ${cam.name}${i < 9 ? ` (${i + 1})` : ""}`;
      b.onclick = () => snapToCamera(i);
      return b;
    }),
  );
  const select = $("renderer");
  select.replaceChildren(
    ...Object.entries(RENDERERS).map(([key, label]) => {
      const has = backends.includes(key);
      const option = new Option(has ? (key === "gpu" ? `${label}: ${state.gpu.name}` : label) : `${label}: unavailable`, key);
      option.disabled = !has;
      if (!has && key === "gpu") option.title = state.gpu?.error || "";
      return option;
    }),
  );
  state.renderer = chooseRenderer(backends, forcedRenderer, state.choice?.renderer);
  if (forcedRenderer === "gpu" && state.renderer !== "gpu") state.gpuNote = `GPU unavailable (${state.gpu?.error}): rendering on the CPU`;
  else if (state.choice?.reason) state.gpuNote = `${RENDERERS[state.renderer]} chosen: ${state.choice.reason}`;
  else state.gpuNote = "";
  select.title = state.gpuNote || (forcedRenderer ? `chosen by the URL (?renderer=${forcedRenderer})` : "");
  select.value = state.renderer;
  const fromHash = decodeHash(location.hash);
  state.view = fromHash ? fromHash.view : info.start_view;
  controls.setSceneScale(info.diagonal);
  controls.setView(state.view);
  setTime(fromHash ? fromHash.timeStep : info.start_time_step);
}

// ---- wiring ------------------------------------------------------------------------------

function wire() {
  $("play").onclick = togglePlay;
  $("step-back").onclick = () => (stopPlayback(), setTime(state.timeStep - 1));
  $("step-forward").onclick = () => (stopPlayback(), setTime(state.timeStep + 1, { streaming: true }));
  $("time").oninput = () => (stopPlayback(), setTime(Number($("time").value), { moving: true }));
  $("time").onchange = () => setTime(Number($("time").value));
  $("reset-view").onclick = resetView;
  $("display").onchange = () => requestFrame();
  $("scale").onchange = () => requestFrame();
  $("quality").onchange = async () => {
    try {
      await client.call("setParams", QUALITY[$("quality").value]);
      requestFrame();
    } catch (e) {
      showError(e.message);
    }
  };
  $("renderer").onchange = () => {
    state.renderer = $("renderer").value;
    state.gpuNote = "";
    client.call("jump").catch(() => {}); // the other path's previous frame is not this one's
    requestFrame();
  };
  $("key-add").onclick = () => (track.add(state.view, state.timeStep), updateKeyCount());
  $("key-clear").onclick = () => (track.clear(), updateKeyCount());
  $("key-play").onclick = playPath;
  $("key-export").onclick = async () => {
    try {
      download(new Blob([await cameraPathJson()], { type: "application/json" }), "camera_path.json");
    } catch (e) {
      showError(e.message);
    }
  };
  $("key-import").onchange = (e) => e.target.files[0] && importPath(e.target.files[0]).catch((err) => showError(err.message));
  $("video-export").onclick = exportVideo;
  $("help-button").onclick = () => $("help").showModal();
  $("folder-input").onchange = (e) => {
    const entries = filesFromInput(e.target);
    open(client.openFiles(entries.map((x) => x.file), entries.map((x) => x.path), gpuWanted, choosing), "from the chosen folder");
  };
  const viewport = $("viewport");
  viewport.addEventListener("dragover", (e) => (e.preventDefault(), viewport.classList.add("dragging")));
  viewport.addEventListener("dragleave", () => viewport.classList.remove("dragging"));
  viewport.addEventListener("drop", async (e) => {
    e.preventDefault();
    viewport.classList.remove("dragging");
    const entries = await filesFromDrop(e.dataTransfer);
    open(client.openFiles(entries.map((x) => x.file), entries.map((x) => x.path), gpuWanted, choosing), "from the dropped folder");
  });
  window.addEventListener("keydown", (e) => {
    if (e.target.closest?.("input, select, textarea") || e.ctrlKey || e.metaKey || e.altKey || !state.info) return;
    if (e.key >= "1" && e.key <= "9") snapToCamera(Number(e.key) - 1);
    else if (e.key === "r" || e.key === "R") resetView();
    else if (e.key === " ") togglePlay();
    else if (e.key === ",") (stopPlayback(), setTime(state.timeStep - 1));
    else if (e.key === ".") (stopPlayback(), setTime(state.timeStep + 1, { streaming: true }));
    else if (e.key === "k" || e.key === "K") (track.add(state.view, state.timeStep), updateKeyCount());
    else if (e.key === "?") $("help").showModal();
    else return;
    e.preventDefault();
  });
}

wire();
const sceneUrl = new URLSearchParams(location.search).get("scene");
if (sceneUrl) open(client.openUrl(new URL(sceneUrl, location.href).href, gpuWanted, choosing), `at ${sceneUrl}`);
else $("landing").hidden = false;

/** Hooks for end-to-end tests and for curious users in the console. */
window.dynview = {
  state,
  /** The worker's memory: `{cache_bytes, wasm_bytes, bytes_read, frames_read}`. */
  memory: () => client.call("memory"),
  firstFrameShown,
  cameraPathJson,
  /** The last finished frame's pixels as `{width, height, rgba: number[]}` (GPU frames are
   * read back from the GPU for this, at their own resolution). */
  lastImage: async () => {
    const done = state.lastDone;
    if (!done) return null;
    const image = done.image || (await client.call("gpuPicture", $("display").value));
    return { width: image.width, height: image.height, rgba: Array.from(image.data) };
  },
  /** Destroys the GPU device, as a driver reset would (tests the fallback). */
  loseGpu: () => client.call("loseGpu"),
};
