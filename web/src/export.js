// Keyframes in and out: the keyframe count, the path exported as a nerfstudio
// camera_path.json or imported from one, and the path played and recorded as a WebM video.

import { $, canvas, gpuCanvas, showError } from "./page.js";
import { renderSize } from "./render.js";
import { state, track } from "./state.js";

/** Hands `blob` to the browser as a download named `name`. */
function download(blob, name) {
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob);
  a.download = name;
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 10_000);
}

/** Shows how many keyframes are recorded (#key-count). */
export function updateKeyCount() {
  $("key-count").textContent = `${track.length} keyframe${track.length === 1 ? "" : "s"}`;
}

/**
 * Exports and imports of the keyframe path.
 * @param {{client: object, playPath: Function}} deps the renderer client (which writes and reads
 *   camera paths) and how the keyframe path is played
 * @returns {{cameraPathJson: Function, downloadCameraPath: Function, importPath: Function,
 *   exportVideo: Function}}
 */
export function createExport({ client, playPath }) {
  /** The keyframes (or the current view alone) as a nerfstudio camera_path.json string. */
  async function cameraPathJson() {
    const keyframes = track.length ? track.keyframes : [{ view: state.view, time_step: state.timeStep }];
    const { width, height } = renderSize();
    return client.call("exportCameraPath", keyframes, width, height, state.info.fps);
  }

  /** Downloads cameraPathJson() as camera_path.json (Export path). */
  async function downloadCameraPath() {
    try {
      download(new Blob([await cameraPathJson()], { type: "application/json" }), "camera_path.json");
    } catch (e) {
      showError(e.message);
    }
  }

  /** Replaces the keyframes with a camera_path.json's. */
  async function importPath(file) {
    const frames = await client.call("importCameraPath", await file.text(), file.name);
    track.clear();
    for (const f of frames) track.add(f.view, f.time_step);
    updateKeyCount();
  }

  /** Plays the keyframe path and records it; the WebM downloads when the playback stops. */
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

  return { cameraPathJson, downloadCameraPath, importPath, exportVideo };
}
