import test from 'node:test';
import assert from 'node:assert/strict';
import { orbit, pan, dolly, fly, zoomFov, viewsClose, cameraBasis } from '../../src/controls.js';

const sub = (a, b) => a.map((x, i) => x - b[i]);
const dot = (a, b) => a.reduce((s, x, i) => s + x * b[i], 0);
const len = (a) => Math.hypot(...a);
const close = (a, b, eps = 1e-9) => assert.ok(Math.abs(a - b) <= eps, `${a} != ${b}`);
const closeVec = (a, b, eps = 1e-9) => a.forEach((x, i) => close(x, b[i], eps));

const VIEW_Y = { eye: [3, 2, 5], target: [1, 0.5, -1], up: [0, 1, 0], vertical_fov_deg: 45 };
// A scene whose world up is -y.
const VIEW_NEG_Y = { eye: [0, -1, 4], target: [0, 0, 0], up: [0, -1, 0], vertical_fov_deg: 60 };
const deepCopy = (v) => JSON.parse(JSON.stringify(v));

test('orbit keeps distance to target, target and world-up', () => {
  for (const v of [VIEW_Y, VIEW_NEG_Y]) {
    const before = deepCopy(v);
    const d0 = len(sub(v.eye, v.target));
    for (const [yaw, pitch] of [[0.3, 0.2], [-1.2, -0.4], [2.5, 0.05], [0, 0]]) {
      const o = orbit(v, yaw, pitch, v.up);
      close(len(sub(o.eye, o.target)), d0, 1e-9);
      closeVec(o.target, v.target);
      closeVec(o.up, v.up.map((x) => x / len(v.up)));
      assert.notEqual(o, v);
    }
    assert.deepEqual(v, before, 'input not mutated');
  }
});

test('orbit yaw preserves elevation; pitch changes it in the expected direction', () => {
  const up = VIEW_NEG_Y.up;
  const elev = (v) => dot(sub(v.eye, v.target), up) / len(sub(v.eye, v.target));
  const yawed = orbit(VIEW_NEG_Y, 0.7, 0, up);
  close(elev(yawed), elev(VIEW_NEG_Y), 1e-12);
  assert.ok(elev(orbit(VIEW_NEG_Y, 0, 0.3, up)) > elev(VIEW_NEG_Y), 'positive pitch raises the eye');
  assert.ok(elev(orbit(VIEW_NEG_Y, 0, -0.3, up)) < elev(VIEW_NEG_Y));
  // Positive yaw moves the eye towards the camera's right.
  const { right } = cameraBasis(VIEW_NEG_Y);
  assert.ok(dot(sub(orbit(VIEW_NEG_Y, 0.1, 0, up).eye, VIEW_NEG_Y.eye), right) > 0);
});

test('orbit pitch is clamped ~2 degrees away from ±worldUp', () => {
  for (const v of [VIEW_Y, VIEW_NEG_Y]) {
    for (const p of [10, -10, 3, -3]) {
      const o = orbit(v, 0.1, p, v.up);
      const f = sub(o.target, o.eye);
      const cos = Math.abs(dot(f, o.up)) / len(f);
      const angleToUp = Math.acos(Math.min(1, cos));
      assert.ok(angleToUp >= 2 * Math.PI / 180 - 1e-9, `angle ${angleToUp}`);
      assert.ok(angleToUp < 3 * Math.PI / 180, 'clamp lands near the limit');
    }
  }
});

test('orbit by 2π yaw returns to start; yaw composes', () => {
  for (const v of [VIEW_Y, VIEW_NEG_Y]) {
    const o = orbit(v, 2 * Math.PI, 0, v.up);
    assert.ok(viewsClose(o, { ...v, up: v.up }, 1e-9));
    let acc = v;
    for (let i = 0; i < 8; i++) acc = orbit(acc, Math.PI / 4, 0, v.up);
    assert.ok(viewsClose(acc, v, 1e-9));
    assert.ok(viewsClose(orbit(orbit(v, 0.4, 0.1, v.up), -0.4, -0.1, v.up), v, 1e-9));
  }
});

test('orbit recovers from a straight-down view', () => {
  const v = { eye: [0, 5, 0], target: [0, 0, 0], up: [0, 1, 0], vertical_fov_deg: 50 };
  const o = orbit(v, 0, 0, v.up);
  assert.ok(o.eye.every(Number.isFinite));
  close(len(o.eye), 5, 1e-9);
});

test('pan moves eye and target by the same vector, perpendicular to the view, with the right sign', () => {
  for (const v of [VIEW_Y, VIEW_NEG_Y]) {
    const { forward, right, up, dist } = cameraBasis(v);
    const h = 2 * dist * Math.tan((v.vertical_fov_deg * Math.PI / 180) / 2);
    const p = pan(v, 0.25, -0.5);
    const de = sub(p.eye, v.eye), dt = sub(p.target, v.target);
    closeVec(de, dt);
    close(dot(de, forward), 0, 1e-9);
    // Drag right => camera moves left (scene moves right); drag up (dy < 0) => camera moves down.
    close(dot(de, right), -0.25 * h, 1e-9);
    close(dot(de, up), -0.5 * h, 1e-9);
    // Full-height drag pans by the visible height.
    close(len(sub(pan(v, 0, 1).eye, v.eye)), h, 1e-9);
    closeVec(p.up, v.up);
    assert.equal(p.vertical_fov_deg, v.vertical_fov_deg);
  }
});

test('pan with -y world up: dragging down moves the camera towards world up', () => {
  const p = pan(VIEW_NEG_Y, 0, 0.1);
  assert.ok(dot(sub(p.eye, VIEW_NEG_Y.eye), VIEW_NEG_Y.up) > 0);
});

test('dolly scales the distance along the view direction and clamps', () => {
  const v = VIEW_Y;
  const d0 = len(sub(v.eye, v.target));
  const { forward } = cameraBasis(v);
  const d = dolly(v, 0.5);
  close(len(sub(d.eye, d.target)), d0 * 0.5);
  closeVec(d.target, v.target);
  closeVec(cameraBasis(d).forward, forward);
  close(len(sub(dolly(v, 1e-6, 1, 100).eye, v.target)), 1);
  close(len(sub(dolly(v, 1e6, 1, 100).eye, v.target)), 100);
  close(len(sub(dolly(v, 2, 0, 1000).eye, v.target)), 2 * d0);
});

test('fly translates eye and target along forward, right and world up', () => {
  for (const v of [VIEW_Y, VIEW_NEG_Y]) {
    const { forward } = cameraBasis(v);
    const f = fly(v, 2, 0, 0);
    closeVec(sub(f.eye, v.eye), forward.map((x) => 2 * x));
    closeVec(sub(f.target, v.target), forward.map((x) => 2 * x));
    const u = fly(v, 0, 0, 1.5);
    closeVec(sub(u.eye, v.eye), v.up.map((x) => 1.5 * x));
    const r = fly(v, 0, 1, 0);
    const dr = sub(r.eye, v.eye);
    close(len(dr), 1);
    close(dot(dr, forward), 0);
    close(dot(dr, v.up), 0);
    close(dot(dr, cameraBasis(v).right), 1);
    assert.ok(viewsClose(fly(fly(v, 1, -2, 3), -1, 2, -3), v, 1e-9));
  }
});

test('zoomFov scales and clamps the field of view', () => {
  assert.equal(zoomFov(VIEW_Y, 0.5).vertical_fov_deg, 22.5);
  assert.equal(zoomFov(VIEW_Y, 100).vertical_fov_deg, 150);
  assert.equal(zoomFov(VIEW_Y, 1e-6).vertical_fov_deg, 1);
});

test('viewsClose', () => {
  assert.ok(viewsClose(VIEW_Y, deepCopy(VIEW_Y)));
  assert.ok(!viewsClose(VIEW_Y, { ...VIEW_Y, eye: [3, 2, 5.1] }));
  assert.ok(viewsClose(VIEW_Y, { ...VIEW_Y, eye: [3, 2, 5.1] }, 0.2));
  assert.ok(!viewsClose(VIEW_Y, { ...VIEW_Y, vertical_fov_deg: 46 }));
});
