// Where the view stands: snapping to an input camera, resetting it, and keeping it (and the
// time) in the URL hash so that a link reopens the same view.

import { encodeHash } from "./hash.js";
import { state } from "./state.js";

let hashTimer = 0;

/** Writes the view and time into the URL hash, once they have rested for a moment. */
export function saveHashSoon() {
  clearTimeout(hashTimer);
  hashTimer = setTimeout(() => state.view && history.replaceState(null, "", encodeHash(state.view, state.timeStep)), 150);
}

/**
 * Moves the view on command.
 * @param {{client: object, controls: object, requestFrame: Function}} deps the renderer client,
 *   the view controls (ViewControls) and how a frame is asked for
 * @returns {{snapToCamera: (index: number) => Promise<void>, resetView: () => void}}
 */
export function createViewMoves({ client, controls, requestFrame }) {
  /** The view of input camera `index` at the current time. */
  async function snapToCamera(index) {
    if (!state.info || index >= state.info.cameras.length) return;
    const view = await client.call("inputView", index, state.timeStep);
    state.view = view;
    controls.setView(view);
    saveHashSoon();
    requestFrame();
  }

  /** The scene's start view. */
  function resetView() {
    state.view = state.info.start_view;
    controls.setView(state.view);
    saveHashSoon();
    requestFrame();
  }

  return { snapToCamera, resetView };
}
