// Camera controls for the dynview web viewer: pure view math plus a DOM binding.
// A "view" is {eye: [x,y,z], target: [x,y,z], up: [x,y,z], vertical_fov_deg}.

const D2R = Math.PI / 180;
/** Closest angle (radians) the view direction may get to ±worldUp when orbiting. */
const PITCH_MARGIN = 2 * D2R;
const MAX_ELEV = Math.PI / 2 - PITCH_MARGIN;

const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const len = (a) => Math.hypot(a[0], a[1], a[2]);
const clamp = (x, lo, hi) => Math.min(hi, Math.max(lo, x));

/** Normalise `a`; returns `fallback` (default +y) when `a` is (near) zero. */
const norm = (a, fallback = [0, 1, 0]) => (len(a) > 1e-12 ? scale(a, 1 / len(a)) : fallback.slice());

/** Any unit vector perpendicular to unit vector `n`. */
const anyPerp = (n) => norm(cross(n, Math.abs(n[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0]));

const copyView = (v) =>
  ({ eye: v.eye.slice(), target: v.target.slice(), up: v.up.slice(), vertical_fov_deg: v.vertical_fov_deg });

/**
 * Orthonormal camera basis of a view: forward (eye->target), right (forward x worldUp),
 * screen-up (right x forward), plus the eye-target distance `dist`.
 * @param {object} view @param {number[]} [worldUp] defaults to view.up
 * @returns {{forward: number[], right: number[], up: number[], dist: number}}
 */
export function cameraBasis(view, worldUp = view.up) {
  const up = norm(worldUp);
  const d = sub(view.target, view.eye);
  const dist = len(d);
  const forward = norm(d, anyPerp(up));
  let right = cross(forward, up);
  right = len(right) > 1e-9 ? norm(right) : anyPerp(forward);
  const screenUp = cross(right, forward);
  return { forward, right, up: screenUp, dist };
}

/**
 * Orbit the eye around the target. Returns a new view; `up` of the result is worldUp.
 * @param {object} view
 * @param {number} yawRad rotation about worldUp (right-handed: positive moves the eye towards camera right)
 * @param {number} pitchRad change of the eye's elevation above the target (positive raises the eye,
 *   so the camera looks further down); the elevation is clamped so the view direction stays at least
 *   ~2 degrees away from ±worldUp
 * @param {number[]} [worldUp] world-up axis (defaults to view.up)
 * @returns {object} new view
 */
export function orbit(view, yawRad, pitchRad, worldUp = view.up) {
  const up = norm(worldUp);
  const offset = sub(view.eye, view.target);
  const dist = len(offset);
  if (dist < 1e-12) return { ...copyView(view), up };
  const along = dot(offset, up);
  let horiz = sub(offset, scale(up, along));
  const hl = len(horiz);
  // Degenerate (eye straight above/below target): the eye moves away from the old screen-up.
  horiz = hl > 1e-9 * dist ? scale(horiz, 1 / hl) : norm(sub(scale(up, dot(view.up, up)), view.up), anyPerp(up));
  // Yaw: rotate the horizontal direction about up (Rodrigues, horiz is perpendicular to up).
  const c = Math.cos(yawRad), s = Math.sin(yawRad);
  const h2 = add(scale(horiz, c), scale(cross(up, horiz), s));
  const elev = clamp(Math.atan2(along, hl) + pitchRad, -MAX_ELEV, MAX_ELEV);
  const o2 = add(scale(h2, dist * Math.cos(elev)), scale(up, dist * Math.sin(elev)));
  return { eye: add(view.target, o2), target: view.target.slice(), up, vertical_fov_deg: view.vertical_fov_deg };
}

/**
 * Pan: move eye and target together in the image plane.
 * Fractions are of the viewport height; a full-height drag moves by the visible
 * height at the target distance (2*dist*tan(fov/2)). Positive dxFrac (drag right)
 * moves the scene right (camera left); positive dyFrac (drag down) moves the scene down.
 * @param {object} view
 * @param {number} dxFrac horizontal drag, fraction of viewport height
 * @param {number} dyFrac vertical drag (screen-down positive), fraction of viewport height
 * @returns {object} new view
 */
export function pan(view, dxFrac, dyFrac) {
  const { right, up, dist } = cameraBasis(view);
  const h = 2 * dist * Math.tan((view.vertical_fov_deg * D2R) / 2);
  const delta = add(scale(right, -dxFrac * h), scale(up, dyFrac * h));
  return { ...copyView(view), eye: add(view.eye, delta), target: add(view.target, delta) };
}

/**
 * Dolly: move the eye along the view direction so that its distance to the
 * target becomes dist*factor (factor < 1 moves closer), clamped to [minDist, maxDist].
 * @param {object} view @param {number} factor @param {number} [minDist=0] @param {number} [maxDist=Infinity]
 * @returns {object} new view
 */
export function dolly(view, factor, minDist = 0, maxDist = Infinity) {
  const { forward, dist } = cameraBasis(view);
  const d = clamp(dist * factor, minDist, maxDist);
  return { ...copyView(view), eye: sub(view.target, scale(forward, d)) };
}

/**
 * Fly: translate eye and target together along camera forward (eye->target),
 * camera right (horizontal, forward x worldUp) and worldUp, by the given distances.
 * @param {object} view
 * @param {number} forward distance along the view direction (scene units)
 * @param {number} right distance to the camera's right
 * @param {number} upward distance along worldUp
 * @param {number[]} [worldUp] defaults to view.up
 * @returns {object} new view
 */
export function fly(view, forward, right, upward, worldUp = view.up) {
  const up = norm(worldUp);
  const b = cameraBasis(view, up);
  const delta = add(add(scale(b.forward, forward), scale(b.right, right)), scale(up, upward));
  return { ...copyView(view), eye: add(view.eye, delta), target: add(view.target, delta) };
}

/**
 * Zoom by scaling the vertical field of view by `factor` (clamped to [minDeg, maxDeg]).
 * @param {object} view @param {number} factor @param {number} [minDeg=1] @param {number} [maxDeg=150]
 * @returns {object} new view
 */
export function zoomFov(view, factor, minDeg = 1, maxDeg = 150) {
  return { ...copyView(view), vertical_fov_deg: clamp(view.vertical_fov_deg * factor, minDeg, maxDeg) };
}

/**
 * True when every component of eye, target, up and the fov differ by at most eps.
 * @param {object} a @param {object} b @param {number} [eps=1e-6] @returns {boolean}
 */
export function viewsClose(a, b, eps = 1e-6) {
  const close3 = (p, q) => p.every((x, i) => Math.abs(x - q[i]) <= eps);
  return close3(a.eye, b.eye) && close3(a.target, b.target) && close3(a.up, b.up) &&
    Math.abs(a.vertical_fov_deg - b.vertical_fov_deg) <= eps;
}

/** Movement key codes -> [forward, right, upward] (fly) or [yaw, pitch] (orbit) directions. */
const FLY_KEYS = { KeyW: [1, 0, 0], KeyS: [-1, 0, 0], KeyA: [0, -1, 0], KeyD: [0, 1, 0], KeyQ: [0, 0, -1], KeyE: [0, 0, 1] };
const ORBIT_KEYS = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, 1], ArrowDown: [0, -1] };
const ORBIT_PER_PX = 4; // radians per element width (yaw) / height (pitch)
const KEY_ORBIT_STEP = 0.03; // radians per 60 Hz frame
const WHEEL_END_MS = 150;

/** Physical key code of a keyboard event (falls back to `key` when `code` is empty). */
function keyCode(e) {
  const k = e.key || '';
  return e.code || (k.length === 1 ? `Key${k.toUpperCase()}` : k);
}

/**
 * Mouse / touch / keyboard camera controller bound to a canvas element.
 * Left drag orbits; right, middle or shift+left drag pans; wheel dollies.
 * One finger orbits; two fingers pinch-dolly and pan. W/S/A/D/Q/E fly
 * (shift = 4x faster), arrow keys orbit, continuously while held.
 */
export class ViewControls {
  /**
   * @param {HTMLElement} element canvas receiving pointer events (keyboard is read on window)
   * @param {{onChange?: (view: object) => void, onInteractionEnd?: () => void}} [callbacks]
   */
  constructor(element, { onChange = () => {}, onInteractionEnd = () => {} } = {}) {
    Object.assign(this, { element, onChange, onInteractionEnd });
    Object.assign(this, {
      _view: null, _worldUp: [0, 1, 0], _scale: 1, _scaleSet: false, _shift: false,
      _pointers: new Map(), // pointerId -> {x, y, mode: 'orbit' | 'pan' | 'touch'}
      _pinch: null, // {dist, mid} of the first two touches
      _keys: new Set(), _raf: 0, _lastFrame: 0, _wheelTimer: 0,
      _prevTouchAction: element.style.touchAction,
    });
    element.style.touchAction = 'none';
    const h = (name, fn, target = element, opts = undefined) => {
      const bound = fn.bind(this);
      target.addEventListener(name, bound, opts);
      return () => target.removeEventListener(name, bound, opts);
    };
    this._off = [
      h('pointerdown', this._onPointerDown), h('pointermove', this._onPointerMove),
      h('pointerup', this._onPointerUp), h('pointercancel', this._onPointerUp),
      h('lostpointercapture', this._onPointerUp), h('wheel', this._onWheel, element, { passive: false }),
      h('contextmenu', (e) => e.preventDefault()),
      h('mousedown', (e) => { if (e.button === 1) e.preventDefault(); }), // no middle-click autoscroll
      h('keydown', this._onKeyDown, window), h('keyup', this._onKeyUp, window),
      h('blur', this._onBlur, window),
    ];
  }

  /** True while a pointer/touch is down, a movement key is held, or a wheel gesture is under way (150 ms). */
  get interacting() {
    return this._pointers.size > 0 || this._keys.size > 0 || this._wheelTimer !== 0;
  }

  /**
   * Set the current view (does not call onChange). Records worldUp = normalised view.up;
   * if setSceneScale was never called, derives the scale from the eye-target distance.
   * @param {object} view
   */
  setView(view) {
    this._view = copyView(view);
    this._worldUp = norm(view.up);
    if (!this._scaleSet) this._scale = Math.max(1e-6, 2 * len(sub(view.target, view.eye)));
  }

  /** @returns {object|null} a copy of the current view (null before setView) */
  getView() { return this._view ? copyView(this._view) : null; }

  /**
   * Set the scene size: fly step = diagonal*0.01 per frame, dolly limits [diagonal*0.01, diagonal*20].
   * @param {number} diagonal scene bounding-box diagonal (scene units)
   */
  setSceneScale(diagonal) {
    if (diagonal > 0 && Number.isFinite(diagonal)) Object.assign(this, { _scale: diagonal, _scaleSet: true });
  }

  /** Remove all listeners, stop the key loop and restore the element's touch-action. */
  dispose() {
    this._off.forEach((off) => off());
    this._off = [];
    if (this._raf) cancelAnimationFrame(this._raf);
    clearTimeout(this._wheelTimer);
    this._raf = this._wheelTimer = 0;
    this._pointers.clear();
    this._keys.clear();
    this.element.style.touchAction = this._prevTouchAction;
  }

  _apply(view) { this._view = view; this.onChange(copyView(view)); }

  _maybeEnd() { if (!this.interacting) this.onInteractionEnd(); }

  _size() { return [this.element.clientWidth || 1, this.element.clientHeight || 1]; }

  _touchPair() {
    const [a, b] = [...this._pointers.values()].filter((p) => p.mode === 'touch');
    return b ? { dist: Math.hypot(a.x - b.x, a.y - b.y), mid: [(a.x + b.x) / 2, (a.y + b.y) / 2] } : null;
  }

  _onPointerDown(e) {
    let mode;
    if (e.pointerType === 'mouse') {
      if (e.button === 0) mode = e.shiftKey ? 'pan' : 'orbit';
      else if (e.button === 1 || e.button === 2) mode = 'pan';
      else return;
    } else mode = 'touch'; // touch and pen
    this._pointers.set(e.pointerId, { x: e.clientX, y: e.clientY, mode });
    try { this.element.setPointerCapture(e.pointerId); } catch { /* ignore */ }
    this._pinch = this._touchPair();
  }

  _onPointerMove(e) {
    const p = this._pointers.get(e.pointerId);
    if (!p || !this._view) return;
    const dx = e.clientX - p.x, dy = e.clientY - p.y;
    [p.x, p.y] = [e.clientX, e.clientY];
    if (dx === 0 && dy === 0) return;
    const [w, hgt] = this._size();
    let v;
    if (p.mode === 'touch' && this._pinch) {
      const now = this._touchPair();
      if (!now) return;
      const f = now.dist > 1 && this._pinch.dist > 1 ? this._pinch.dist / now.dist : 1;
      v = dolly(this._view, f, this._scale * 0.01, this._scale * 20);
      v = pan(v, (now.mid[0] - this._pinch.mid[0]) / hgt, (now.mid[1] - this._pinch.mid[1]) / hgt);
      this._pinch = now;
    } else if (p.mode === 'orbit' || p.mode === 'touch') {
      v = orbit(this._view, (-dx / w) * ORBIT_PER_PX, (dy / hgt) * ORBIT_PER_PX, this._worldUp);
    } else {
      v = pan(this._view, dx / hgt, dy / hgt);
    }
    this._apply(v);
  }

  _onPointerUp(e) {
    if (!this._pointers.delete(e.pointerId)) return;
    this._pinch = this._touchPair();
    this._maybeEnd();
  }

  _onWheel(e) {
    e.preventDefault();
    if (!this._view) return;
    const unit = e.deltaMode === 1 ? 16 : e.deltaMode === 2 ? this._size()[1] : 1;
    this._apply(dolly(this._view, Math.exp(e.deltaY * unit * 0.001), this._scale * 0.01, this._scale * 20));
    clearTimeout(this._wheelTimer);
    this._wheelTimer = setTimeout(() => { this._wheelTimer = 0; this._maybeEnd(); }, WHEEL_END_MS);
  }

  _ignoreKey(e) {
    const t = e.target;
    return e.ctrlKey || e.metaKey || e.altKey ||
      !!(t && (t.isContentEditable || /^(INPUT|SELECT|TEXTAREA)$/.test(t.tagName || '')));
  }

  _onKeyDown(e) {
    this._shift = e.shiftKey;
    const code = keyCode(e);
    if (!(code in FLY_KEYS || code in ORBIT_KEYS) || this._ignoreKey(e)) return;
    e.preventDefault();
    if (this._keys.has(code)) return;
    this._keys.add(code);
    if (!this._raf) {
      this._lastFrame = 0;
      this._raf = requestAnimationFrame((t) => this._frame(t));
    }
  }

  _onKeyUp(e) {
    this._shift = e.shiftKey;
    const code = keyCode(e);
    if (!this._keys.delete(code)) return;
    e.preventDefault();
    if (this._keys.size === 0) this._stopKeys();
  }

  _onBlur() { // keyup never arrives after focus loss
    if (this._keys.size) { this._keys.clear(); this._stopKeys(); }
  }

  _stopKeys() { cancelAnimationFrame(this._raf); this._raf = 0; this._maybeEnd(); }

  _frame(t) {
    this._raf = 0;
    if (this._keys.size === 0) return;
    // Frames elapsed at 60 Hz, so speed does not depend on the display refresh rate.
    const frames = this._lastFrame ? clamp((t - this._lastFrame) / (1000 / 60), 0, 4) : 1;
    this._lastFrame = t;
    if (this._view) {
      const m = [0, 0, 0], o = [0, 0];
      for (const k of this._keys) {
        if (FLY_KEYS[k]) FLY_KEYS[k].forEach((x, i) => { m[i] += x; });
        if (ORBIT_KEYS[k]) ORBIT_KEYS[k].forEach((x, i) => { o[i] += x; });
      }
      const step = this._scale * 0.01 * frames * (this._shift ? 4 : 1);
      const a = KEY_ORBIT_STEP * frames;
      let v = this._view;
      if (m.some((x) => x !== 0)) v = fly(v, m[0] * step, m[1] * step, m[2] * step, this._worldUp);
      if (o.some((x) => x !== 0)) v = orbit(v, o[0] * a, o[1] * a, this._worldUp);
      if (v !== this._view) this._apply(v);
    }
    this._raf = requestAnimationFrame((tt) => this._frame(tt));
  }
}
