// Rendering the view: frame requests to the worker (only the coarse levels while the view
// moves, the full frame once it rests), and what comes back: frames drawn into the page with
// their overlay, loading progress, and the GPU's loss (the CPU takes over).

import { RENDERERS } from "./client.js";
import { $, canvas, ctx, gpuCanvas, hide, scratch } from "./page.js";
import { state } from "./state.js";

/** Iteration presets of the quality control (fields of dynview-core's RenderParams). */
export const QUALITY = {
  fast: { outer_iterations: 1, outer_iterations_finest: 1, depth_sweeps: 12, color_sweeps: 6 },
  balanced: {},
  best: { outer_iterations: 3, outer_iterations_finest: 2, depth_sweeps: 32, color_sweeps: 16 },
};
/** Coarsest levels shown while the view moves (levels >= this are rendered, then it waits). */
const MOVING_MAX_LEVEL = 2;
/** How long the view must rest before the full frame is rendered. */
const REST_MS = 120;

/** The frame size the Scale control asks for. */
export function renderSize() {
  const cam = state.info.cameras[0];
  const scale = Number($("scale").value);
  return { width: Math.max(16, Math.round(cam.width * scale)), height: Math.max(9, Math.round(cam.height * scale)) };
}

/** Shows the loading progress of a time step (a "progress" message). */
export function showProgress(msg) {
  const el = $("loading");
  el.hidden = false;
  const mb = (msg.stats.bytes_read / 1e6).toFixed(1);
  el.querySelector(".loading-text").textContent =
    `Loading time step ${msg.time_step + 1}: ${msg.done}/${msg.total} frames, ${mb} MB read, ${msg.stats.frames_read} frames in all`;
  el.querySelector(".progress-fill").style.width = `${(100 * msg.done) / Math.max(1, msg.total)}%`;
}

/**
 * The page's frames, rendered by `client` (a RendererClient).
 * @param {{client: object, isInteracting: () => boolean, onFinished: () => void}} deps
 *   `isInteracting`: whether the user still holds the view (then it is not refined yet);
 *   `onFinished`: called after each finished frame (playback goes on from there)
 * @returns {{requestFrame: Function, showFrame: Function, fallBackToCpu: Function,
 *   firstFrameShown: Promise<void>}}
 */
export function createFrames({ client, isInteracting, onFinished }) {
  let restTimer = 0;
  let firstFrame;
  const firstFrameShown = new Promise((resolve) => (firstFrame = resolve));

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
    if (moving) restTimer = setTimeout(() => !isInteracting() && requestFrame({ streaming }), REST_MS);
    return state.latestId;
  }

  /** Shows a frame (a "frame" message): draws it, updates the overlay, and when it is finished
   * records it and lets playback go on. */
  function showFrame(msg) {
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
    onFinished();
  }

  /** The GPU path failed (device lost, GPU error): the CPU path takes over, and says so. */
  function fallBackToCpu(message) {
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

  return { requestFrame, showFrame, fallBackToCpu, firstFrameShown };
}
