// Time and playback: the time slider, play/pause, and playing the keyframe path (which a video
// export records; stopping the playback ends the recording).

import { playbackFrames } from "./keyframes.js";
import { $, showError } from "./page.js";
import { state, track } from "./state.js";
import { saveHashSoon } from "./view.js";

/**
 * The page's playback.
 * @param {{client: object, controls: object, requestFrame: Function}} deps the renderer client,
 *   the view controls (ViewControls) and how a frame is asked for
 * @returns {{setTime: Function, togglePlay: Function, stopPlayback: Function,
 *   advancePlayback: Function, playPath: Function}}
 */
export function createPlayback({ client, controls, requestFrame }) {
  /** Moves to time step `t` (clamped) and renders it. */
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

  /** Stops playing the time line or the path (and ends a video being recorded). */
  function stopPlayback() {
    if (!state.playing && !state.path) return;
    state.playing = false;
    state.path = null;
    clearTimeout(state.playbackTimer);
    $("play").innerHTML = "&#9654;";
    $("play").setAttribute("aria-label", "Play");
    if (state.recorder) finishVideo();
  }

  /** Ends the video recording of the path (its recorder then downloads it). */
  function finishVideo() {
    const { recorder } = state.recorder;
    state.recorder = null;
    recorder.stop();
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

  /** Plays the keyframe path from its start. */
  function playPath() {
    if (track.length === 0) return showError("Record at least one keyframe (+ Keyframe or K) first.");
    stopPlayback();
    state.path = playbackFrames(track, state.info.fps, 2);
    state.pathIndex = 0;
    showPathFrame(false);
  }

  return { setTime, togglePlay, stopPlayback, advancePlayback, playPath };
}
