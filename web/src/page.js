// The page's elements and URL options, and its messages (errors, the loading box): what the
// other modules of the page draw into and read. The URL's options are read once, at load.

import { state } from "./state.js";

/** The element with id `id`. */
export const $ = (id) => document.getElementById(id);

/** The canvas CPU frames are drawn into (#view). */
export const canvas = $("view");
/** Its 2D context. */
export const ctx = canvas.getContext("2d");
/** An off-page canvas a CPU frame is put into before it is scaled onto #view. */
export const scratch = document.createElement("canvas");
/** The canvas the worker's GPU path draws into (#view-gpu, an OffscreenCanvas once handed over). */
export const gpuCanvas = $("view-gpu");

const search = new URLSearchParams(location.search);
/** The URL's options: `?embed` (inside a `<dynview-viewer>` element, src/embed.js: the view and
 * the timeline only), `?renderer=cpu|gpu` (forces a renderer when it is available),
 * `?renderer-trial` (the worker times both renderers even on a software GPU; tests) and
 * `?scene=URL` (the scene package to open). */
export const urlOptions = Object.freeze({
  embed: search.has("embed"),
  renderer: search.get("renderer"),
  rendererTrial: search.has("renderer-trial"),
  scene: search.get("scene"),
});

/** Hides the element with id `id`. */
export function hide(id) {
  $(id).hidden = true;
}

/** Shows `message` in #message (and stops waiting for a frame). */
export function showError(message) {
  const el = $("message");
  el.textContent = message;
  el.hidden = false;
  hide("loading");
  state.rendering = false;
}
