import test from 'node:test';
import assert from 'node:assert/strict';
import { KeyframeTrack, playbackFrames } from '../../src/keyframes.js';

const view = (x, fov = 45, up = [0, 1, 0]) =>
  ({ eye: [x, 1, 5 + x], target: [x, 0, 0], up, vertical_fov_deg: fov });

function track3() {
  const t = new KeyframeTrack();
  t.add(view(0, 40), 0);
  t.add(view(2, 50, [0, 0, 1]), 10);
  t.add(view(7, 60), 3);
  return t;
}

test('empty and single-keyframe tracks', () => {
  const t = new KeyframeTrack();
  assert.equal(t.length, 0);
  assert.equal(t.sample(0.5), null);
  assert.deepEqual(playbackFrames(t, 30, 1), []);
  t.add(view(1), 7);
  for (const u of [0, 0.3, 1]) assert.deepEqual(t.sample(u), { view: view(1), time_step: 7 });
  assert.equal(playbackFrames(t, 30, 2).length, 1);
  t.clear();
  assert.equal(t.length, 0);
});

test('add copies the view; keyframes returns copies', () => {
  const t = new KeyframeTrack();
  const v = view(1);
  t.add(v, 2);
  v.eye[0] = 99;
  assert.equal(t.keyframes[0].view.eye[0], 1);
  t.keyframes[0].view.eye[0] = 42;
  assert.equal(t.keyframes[0].view.eye[0], 1);
  assert.deepEqual(t.keyframes, [{ view: view(1), time_step: 2 }]);
});

test('sampling hits the keyframes at the ends and at segment boundaries', () => {
  const t = track3();
  const k = t.keyframes;
  assert.deepEqual(t.sample(0), k[0]);
  assert.deepEqual(t.sample(0.5), k[1]);
  assert.deepEqual(t.sample(1), k[2]);
  assert.deepEqual(t.sample(-1), k[0], 'clamped below');
  assert.deepEqual(t.sample(2), k[2], 'clamped above');
  // Boundaries computed with rounding error still land on keyframes.
  const t4 = new KeyframeTrack();
  for (let i = 0; i < 4; i++) t4.add(view(i * i), i);
  for (let i = 0; i < 4; i++) assert.deepEqual(t4.sample(i * (1 / 3)), t4.keyframes[i]);
});

test('interpolated samples are smooth and well formed', () => {
  const t = track3();
  let prev = t.sample(0);
  for (let i = 1; i <= 200; i++) {
    const s = t.sample(i / 200);
    assert.ok(Number.isInteger(s.time_step), `time step ${s.time_step}`);
    assert.ok(s.time_step >= 0 && s.time_step <= 10);
    assert.ok(Math.abs(Math.hypot(...s.view.up) - 1) < 1e-9, 'up normalised');
    assert.ok(s.view.vertical_fov_deg >= 40 && s.view.vertical_fov_deg <= 60);
    const step = Math.hypot(...s.view.eye.map((x, j) => x - prev.view.eye[j]));
    assert.ok(step < 0.2, `continuous eye path (step ${step})`);
    prev = s;
  }
  // Linear quantities at a segment midpoint.
  const mid = t.sample(0.25);
  assert.equal(mid.view.vertical_fov_deg, 45);
  assert.equal(mid.time_step, 5);
  // Collinear, evenly spaced targets stay on the line (Catmull-Rom reproduces lines).
  const lin = new KeyframeTrack();
  for (let i = 0; i < 3; i++) lin.add(view(i), i);
  const s = lin.sample(0.3);
  assert.ok(Math.abs(s.view.target[0] - 0.6) < 1e-12);
  assert.equal(s.view.target[1], 0);
});

test('playbackFrames count and ends', () => {
  const t = track3();
  const frames = playbackFrames(t, 30, 2);
  assert.equal(frames.length, 30 * 2 * 2 + 1);
  assert.deepEqual(frames[0], t.keyframes[0]);
  assert.deepEqual(frames[60], t.keyframes[1]);
  assert.deepEqual(frames.at(-1), t.keyframes[2]);
  assert.ok(frames.every((f) => Number.isInteger(f.time_step)));
  // At least one frame per segment, both ends included.
  assert.equal(playbackFrames(t, 1, 0.01).length, 3);
  assert.equal(playbackFrames(t, 24, 0.5).length, 12 * 2 + 1);
  assert.throws(() => playbackFrames(t, 0, 1), RangeError);
});
