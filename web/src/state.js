// The viewer page's state: the one object its modules share (the end-to-end tests read it as
// `window.dynview.state`), and the keyframe track. Nothing here touches the page or the worker.

import { KeyframeTrack } from "./keyframes.js";

/** What the page shows and where it stands; every module reads and writes these fields. */
export const state = {
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

/** The recorded keyframes (+ Keyframe, K, Import path). */
export const track = new KeyframeTrack();
