// Opening a scene: the loading box while the worker opens it, then the page set up for it
// (canvas size, time slider, camera buttons, the Renderer menu and its choice, and the view
// and time from the URL hash or the scene's start).

import { RENDERERS, chooseRenderer } from "./client.js";
import { decodeHash } from "./hash.js";
import { $, canvas, hide, showError, urlOptions } from "./page.js";
import { state } from "./state.js";

/** Views at most this wide are a phone's: they get the phone's memory budget. */
const PHONE_MAX_WIDTH_PX = 600;
/** Decoded time steps a phone keeps (about one step of six 960x540 cameras; 256 MiB elsewhere). */
const PHONE_CACHE_BUDGET_BYTES = 64 << 20;

/**
 * The page's scene opening.
 * @param {{client: object, controls: object, stopPlayback: Function, setTime: Function,
 *   snapToCamera: Function}} deps the renderer client, the view controls (ViewControls), and
 *   the playback and view moves the opened scene is wired to
 * @returns {{open: (opening: Promise<object>, label: string) => Promise<void>}}
 */
export function createOpening({ client, controls, stopPlayback, setTime, snapToCamera }) {
  /** Waits for `opening` (a RendererClient's openUrl or openFiles), showing `label` meanwhile,
   * and sets the page up for the scene, or says why it could not be opened. */
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
    const forcedRenderer = urlOptions.renderer;
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

  return { open };
}
