import test from 'node:test';
import assert from 'node:assert/strict';
import {
  FROM_WORKER,
  TO_WORKER,
  callMessage,
  canvasMessage,
  cpuFrameMessage,
  errorMessage,
  gpuFrameMessage,
  gpuLostMessage,
  idleMessage,
  idleSettles,
  isFromWorker,
  isOpening,
  isToWorker,
  openFilesMessage,
  openUrlMessage,
  openedMessage,
  prefetchMessage,
  progressMessage,
  renderMessage,
  replyMessage,
  requestId,
} from '../../src/protocol.js';

test('the type names are the ones on the wire, and cannot be changed', () => {
  assert.deepEqual(Object.values(TO_WORKER), ['canvas', 'open', 'open-files', 'render', 'call', 'prefetch']);
  assert.deepEqual(Object.values(FROM_WORKER), ['opened', 'frame', 'progress', 'idle', 'gpu-lost', 'reply', 'error']);
  assert.ok(Object.isFrozen(TO_WORKER) && Object.isFrozen(FROM_WORKER));
});

test('messages to the worker carry their fields', () => {
  const canvas = {};
  assert.deepEqual(canvasMessage(canvas), { type: 'canvas', canvas });
  assert.deepEqual(openUrlMessage('http://x/scene/'), { type: 'open', url: 'http://x/scene/', gpu: false, choose: false, trial: false });
  assert.deepEqual(openUrlMessage('u', true, { choose: true }), { type: 'open', url: 'u', gpu: true, choose: true, trial: false });
  assert.deepEqual(openFilesMessage(['f'], ['a/f'], true, { choose: true, trial: true }),
    { type: 'open-files', files: ['f'], paths: ['a/f'], gpu: true, choose: true, trial: true });
  assert.deepEqual(callMessage(7, 'inputView', [1, 2]), { type: 'call', id: 7, method: 'inputView', args: [1, 2] });
  assert.deepEqual(prefetchMessage(4), { type: 'prefetch', time_step: 4 });
});

test('a render message copies the request and adds its id', () => {
  const request = { renderer: 'cpu', time_step: 3, width: 64, height: 36, max_level: null };
  const msg = renderMessage(request, 12);
  assert.deepEqual(msg, { type: 'render', request: { ...request, id: 12 } });
  assert.equal(request.id, undefined, 'the request itself is left as it was');
});

test('messages from the worker carry their fields', () => {
  const info = { name: 'scene' };
  assert.deepEqual(openedMessage(info, ['cpu'], { error: 'none' }, { renderer: null, reason: '' }),
    { type: 'opened', info, backends: ['cpu'], gpu: { error: 'none' }, choice: { renderer: null, reason: '' } });
  assert.deepEqual(progressMessage(2, { bytes_read: 10 }, 1, 6), { type: 'progress', time_step: 2, stats: { bytes_read: 10 }, done: 1, total: 6 });
  assert.deepEqual(idleMessage(7), { type: 'idle', last_id: 7 });
  assert.deepEqual(gpuLostMessage('device lost'), { type: 'gpu-lost', message: 'device lost' });
  assert.deepEqual(replyMessage(3, 42), { type: 'reply', id: 3, value: 42 });
  assert.deepEqual(errorMessage(3, 'bad'), { type: 'error', id: 3, message: 'bad', open: false });
  assert.deepEqual(errorMessage(undefined, 'no file', true), { type: 'error', id: undefined, message: 'no file', open: true });
});

test('frame messages: the CPU report with its picture, the GPU report as it is', () => {
  const image = { width: 8, height: 4, data: new Uint8ClampedArray(128) };
  const report = { level: 1, done: false, elapsed_ms: 5, temporal_used: true, ignored: 1 };
  assert.deepEqual(cpuFrameMessage(9, report, image, null), {
    type: 'frame', id: 9, level: 1, done: false, width: 8, height: 4, image, elapsed_ms: 5, temporal_used: true, last: null,
  });
  const gpu = { level: 0, done: true, width: 8, height: 4, elapsed_ms: 3, last: { wall_ms: 3 } };
  assert.deepEqual(gpuFrameMessage(10, gpu), { type: 'frame', id: 10, gpu: true, level: 0, done: true, width: 8, height: 4, elapsed_ms: 3, last: null });
});

test('each side knows its own messages and no others', () => {
  for (const msg of [canvasMessage({}), openUrlMessage('u'), renderMessage({}, 1), callMessage(1, 'info', []), prefetchMessage(0)]) {
    assert.ok(isToWorker(msg), msg.type);
    assert.ok(!isFromWorker(msg), msg.type);
  }
  for (const msg of [idleMessage(1), replyMessage(1, 0), errorMessage(1, 'x'), gpuLostMessage('x'), progressMessage(0, {}, 0, 1)]) {
    assert.ok(isFromWorker(msg), msg.type);
    assert.ok(!isToWorker(msg), msg.type);
  }
  for (const junk of [null, undefined, 'frame', 3, {}, { type: 'bogus' }]) {
    assert.ok(!isToWorker(junk) && !isFromWorker(junk), String(junk));
  }
});

test('openings and the ids errors answer', () => {
  assert.ok(isOpening(openUrlMessage('u')));
  assert.ok(isOpening(openFilesMessage([], [])));
  assert.ok(!isOpening(renderMessage({}, 1)) && !isOpening(callMessage(1, 'info', [])));
  assert.equal(requestId(callMessage(5, 'info', [])), 5);
  assert.equal(requestId(renderMessage({ time_step: 0 }, 6)), 6);
  assert.equal(requestId(prefetchMessage(2)), undefined);
  assert.equal(requestId(openUrlMessage('u')), undefined);
});

test('an idle posted before the worker took the newest request does not settle it', () => {
  // The page asked for request 6 while the worker finished 5 and said it was idle.
  assert.equal(idleSettles(idleMessage(5), 6), false);
  assert.equal(idleSettles(idleMessage(6), 6), true);
  assert.equal(idleSettles(idleMessage(0), 0), true, 'nothing asked yet: settled');
});
