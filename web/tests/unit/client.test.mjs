import test from 'node:test';
import assert from 'node:assert/strict';
import { chooseRenderer } from '../../src/client.js';

test('the GPU is chosen when the worker has it and the browser has WebGPU', () => {
  assert.equal(chooseRenderer(['cpu', 'gpu'], true), 'gpu');
  assert.equal(chooseRenderer(['cpu', 'gpu'], false), 'cpu');
  assert.equal(chooseRenderer(['cpu'], true), 'cpu');
});

test('the URL can force either renderer, but not one the worker lacks', () => {
  assert.equal(chooseRenderer(['cpu', 'gpu'], true, 'cpu'), 'cpu');
  assert.equal(chooseRenderer(['cpu', 'gpu'], false, 'gpu'), 'gpu');
  assert.equal(chooseRenderer(['cpu'], true, 'gpu'), 'cpu');
  assert.equal(chooseRenderer(['cpu', 'gpu'], true, 'bogus'), 'gpu');
});
