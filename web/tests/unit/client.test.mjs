import test from 'node:test';
import assert from 'node:assert/strict';
import { chooseRenderer } from '../../src/client.js';

test("the worker's choice is kept when the worker has that renderer", () => {
  assert.equal(chooseRenderer(['cpu', 'gpu'], null, 'gpu'), 'gpu');
  assert.equal(chooseRenderer(['cpu', 'gpu'], null, 'cpu'), 'cpu');
  assert.equal(chooseRenderer(['cpu'], null, 'gpu'), 'cpu');
});

test('without a choice the CPU is used, even where the worker has a GPU', () => {
  assert.equal(chooseRenderer(['cpu', 'gpu']), 'cpu');
  assert.equal(chooseRenderer(['cpu', 'gpu'], null, null), 'cpu');
});

test('the URL can force either renderer over the choice, but not one the worker lacks', () => {
  assert.equal(chooseRenderer(['cpu', 'gpu'], 'cpu', 'gpu'), 'cpu');
  assert.equal(chooseRenderer(['cpu', 'gpu'], 'gpu', 'cpu'), 'gpu');
  assert.equal(chooseRenderer(['cpu'], 'gpu', 'cpu'), 'cpu');
  assert.equal(chooseRenderer(['cpu', 'gpu'], 'bogus', 'gpu'), 'gpu');
});
