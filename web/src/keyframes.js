// Camera keyframe tracks for the dynview web viewer: record views, sample a
// smooth path through them, and generate playback frames.
// A "view" is {eye: [x,y,z], target: [x,y,z], up: [x,y,z], vertical_fov_deg}.

const lerp = (a, b, t) => a + (b - a) * t;

function copyView(v) {
  return { eye: v.eye.slice(), target: v.target.slice(), up: v.up.slice(), vertical_fov_deg: v.vertical_fov_deg };
}

/** Uniform Catmull-Rom between p1 (t=0) and p2 (t=1), componentwise on 3-vectors. */
function catmullRom(p0, p1, p2, p3, t) {
  const t2 = t * t, t3 = t2 * t;
  return p1.map((_, i) => 0.5 * (2 * p1[i] + (p2[i] - p0[i]) * t +
    (2 * p0[i] - 5 * p1[i] + 4 * p2[i] - p3[i]) * t2 + (3 * p1[i] - p0[i] - 3 * p2[i] + p3[i]) * t3));
}

/** Reflect b through a (2a - b): phantom control point beyond an end of the track. */
const reflect = (a, b) => a.map((x, i) => 2 * x - b[i]);

/**
 * An ordered list of camera keyframes ({view, time_step}) that can be sampled
 * as a smooth path: Catmull-Rom on eye and target, linear (re-normalised) on up,
 * linear on fov, and linear time step rounded to an integer.
 */
export class KeyframeTrack {
  /** Create an empty track. */
  constructor() {
    /** @type {{view: object, time_step: number}[]} */
    this._keys = [];
  }

  /**
   * Append a keyframe (the view is copied).
   * @param {object} view camera view
   * @param {number} timeStep scene time step shown at this keyframe (rounded to an integer)
   * @returns {number} the new number of keyframes
   */
  add(view, timeStep) {
    this._keys.push({ view: copyView(view), time_step: Math.round(timeStep) });
    return this._keys.length;
  }

  /** Remove all keyframes. */
  clear() {
    this._keys = [];
  }

  /** @returns {number} number of keyframes */
  get length() {
    return this._keys.length;
  }

  /** @returns {{view: object, time_step: number}[]} copies of the keyframes, in order */
  get keyframes() {
    return this._keys.map((k) => ({ view: copyView(k.view), time_step: k.time_step }));
  }

  /**
   * Sample the track at parameter u in [0, 1] (clamped). The n keyframes split
   * [0, 1] into n-1 equal segments, so u = i/(n-1) returns keyframe i exactly.
   * With one keyframe, returns (a copy of) it; with none, returns null.
   * @param {number} u
   * @returns {{view: object, time_step: number} | null}
   */
  sample(u) {
    const k = this._keys, n = k.length;
    if (n === 0) return null;
    if (n === 1) return { view: copyView(k[0].view), time_step: k[0].time_step };
    const segs = n - 1;
    let s = Math.min(1, Math.max(0, Number.isFinite(u) ? u : 0)) * segs;
    if (Math.abs(s - Math.round(s)) < 1e-9) s = Math.round(s); // land exactly on keyframes
    const i = Math.min(Math.floor(s), segs - 1);
    const t = s - i;
    const a = k[i], b = k[i + 1];
    if (t === 0) return { view: copyView(a.view), time_step: a.time_step };
    if (t === 1) return { view: copyView(b.view), time_step: b.time_step };
    const field = (f) => {
      const p1 = a.view[f], p2 = b.view[f];
      const p0 = i > 0 ? k[i - 1].view[f] : reflect(p1, p2);
      const p3 = i + 2 < n ? k[i + 2].view[f] : reflect(p2, p1);
      return catmullRom(p0, p1, p2, p3, t);
    };
    let up = a.view.up.map((x, j) => lerp(x, b.view.up[j], t));
    const l = Math.hypot(...up);
    up = l > 1e-9 ? up.map((x) => x / l) : (t < 0.5 ? a.view.up : b.view.up).slice();
    return {
      view: {
        eye: field('eye'),
        target: field('target'),
        up,
        vertical_fov_deg: lerp(a.view.vertical_fov_deg, b.view.vertical_fov_deg, t),
      },
      time_step: Math.round(lerp(a.time_step, b.time_step, t)),
    };
  }
}

/**
 * Frames for playing back a track: each segment (between consecutive keyframes)
 * lasts secondsPerSegment seconds, i.e. max(1, round(fps*secondsPerSegment))
 * frame intervals, and both ends are included, so a track of n >= 2 keyframes
 * gives perSegment*(n-1)+1 frames with every keyframe hit exactly. A track of one
 * keyframe gives that single frame; an empty track gives [].
 * @param {KeyframeTrack} track
 * @param {number} fps frames per second (> 0)
 * @param {number} secondsPerSegment duration of each segment in seconds (> 0)
 * @returns {{view: object, time_step: number}[]}
 */
export function playbackFrames(track, fps, secondsPerSegment) {
  if (!(fps > 0) || !(secondsPerSegment > 0)) throw new RangeError('fps and secondsPerSegment must be > 0');
  const n = track.length;
  if (n === 0) return [];
  if (n === 1) return [track.sample(0)];
  const perSeg = Math.max(1, Math.round(fps * secondsPerSegment));
  const total = perSeg * (n - 1);
  const frames = [];
  for (let f = 0; f <= total; f++) frames.push(track.sample(f / total));
  return frames;
}
