// The viewer page's wiring: builds the renderer client (client.js), the frames (render.js),
// the view controls, playback, keyframe export and scene opening, ties them to the page's
// buttons, keys and drops, and opens the URL's scene. All rendering happens in the worker: CPU
// frames arrive as pictures drawn into #view; GPU frames are drawn by the worker into #view-gpu
// (an OffscreenCanvas), which then covers #view. What each part does lives in its module:
//
//   state.js     the shared state (window.dynview.state) and the keyframe track
//   page.js      the page's elements, URL options and messages
//   render.js    frame requests, frames shown, loading progress, GPU loss
//   playback.js  time slider, play/pause, the keyframe path's playback
//   view.js      snapping and resetting the view, the URL hash
//   export.js    camera_path.json out and in, WebM video
//   opening.js   opening a scene and setting the page up for it
//
// The parts are made here, in order; a callback handed to an earlier one may name a later one,
// which exists by the time any event calls it.

import { RendererClient } from "./client.js";
import { ViewControls } from "./controls.js";
import { createExport, updateKeyCount } from "./export.js";
import { filesFromDrop, filesFromInput } from "./files.js";
import { createOpening } from "./opening.js";
import { $, canvas, gpuCanvas, showError, urlOptions } from "./page.js";
import { createPlayback } from "./playback.js";
import { idleSettles } from "./protocol.js";
import { QUALITY, createFrames, showProgress } from "./render.js";
import { state, track } from "./state.js";
import { createViewMoves, saveHashSoon } from "./view.js";

if (urlOptions.embed) document.body.classList.add("embed");

const client = new RendererClient({
  onFrame: (msg) => frames.showFrame(msg),
  onProgress: showProgress,
  onError: showError,
  onIdle: (msg) => idleSettles(msg, state.latestId) && (state.rendering = false),
  onGpuLost: (message) => frames.fallBackToCpu(message),
});
/** Whether to set up the GPU path (also when the URL starts on the CPU: the menu can switch). */
const gpuWanted = "gpu" in navigator && "transferControlToOffscreen" in gpuCanvas;
if (gpuWanted) client.setCanvas(gpuCanvas.transferControlToOffscreen());
/** How the worker picks the renderer: unless the URL forces one; `?renderer-trial` times both
 * even on a software GPU (tests). */
const choosing = { choose: gpuWanted && !urlOptions.renderer, trial: urlOptions.rendererTrial };
const frames = createFrames({ client, isInteracting: () => controls.interacting, onFinished: () => playback.advancePlayback() });
const { requestFrame } = frames;
const controls = new ViewControls(canvas, {
  onChange: (view) => {
    state.view = view;
    playback.stopPlayback();
    requestFrame({ moving: true });
    saveHashSoon();
  },
  onInteractionEnd: () => requestFrame({ moving: false }),
});
const playback = createPlayback({ client, controls, requestFrame });
const { setTime, togglePlay, stopPlayback, playPath } = playback;
const { snapToCamera, resetView } = createViewMoves({ client, controls, requestFrame });
const { cameraPathJson, downloadCameraPath, importPath, exportVideo } = createExport({ client, playPath });
const { open } = createOpening({ client, controls, stopPlayback, setTime, snapToCamera });

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
  $("key-export").onclick = downloadCameraPath;
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
const sceneUrl = urlOptions.scene;
if (sceneUrl) open(client.openUrl(new URL(sceneUrl, location.href).href, gpuWanted, choosing), `at ${sceneUrl}`);
else $("landing").hidden = false;

/** Hooks for end-to-end tests and for curious users in the console. */
window.dynview = {
  state,
  /** The worker's memory: `{cache_bytes, wasm_bytes, bytes_read, frames_read}`. */
  memory: () => client.call("memory"),
  firstFrameShown: frames.firstFrameShown,
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
