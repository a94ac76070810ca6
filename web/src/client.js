// The page's side of the renderer worker: opening scenes, render requests (the newest one
// wins), small queries, and which renderer backs the view. The messages are protocol.js's.

import {
  FROM_WORKER,
  callMessage,
  canvasMessage,
  isFromWorker,
  openFilesMessage,
  openUrlMessage,
  prefetchMessage,
  renderMessage,
} from "./protocol.js";

/** Renderers the page knows; a worker reports which it has (`backends`). */
export const RENDERERS = {
  cpu: "CPU (wasm, worker)",
  gpu: "GPU (WebGPU)",
};

/**
 * Picks the renderer at start: the one the URL forces (`?renderer=cpu|gpu`) when the worker
 * has it, else the one the worker chose (`choice`: it never picks a software GPU and times
 * both when the GPU is real), else the CPU.
 * @param {string[]} backends what the worker can run
 * @param {string | null} [forced] the renderer the URL asks for
 * @param {string | null} [chosen] the worker's choice
 */
export function chooseRenderer(backends, forced = null, chosen = null) {
  if (forced && backends.includes(forced)) return forced;
  if (chosen && backends.includes(chosen)) return chosen;
  return "cpu";
}

/** Talks to `worker.js`. Frames and errors arrive through the callbacks. */
export class RendererClient {
  /**
   * @param {{onFrame: Function, onProgress: Function, onError: Function, onIdle: Function,
   *   onGpuLost: Function}} handlers
   */
  constructor(handlers) {
    this.handlers = handlers;
    this.worker = new Worker(new URL("./worker.js", import.meta.url), { type: "module" });
    this.nextId = 1;
    this.replies = new Map();
    this.openWaiter = null;
    this.worker.onmessage = (event) => this.receive(event.data);
    this.worker.onerror = (event) => {
      const message = `the renderer worker failed to start: ${event.message || "unknown error"}`;
      if (this.openWaiter) this.openWaiter.reject(new Error(message));
      else handlers.onError(message);
    };
  }

  receive(msg) {
    if (!isFromWorker(msg)) return;
    switch (msg.type) {
      case FROM_WORKER.OPENED:
        this.openWaiter?.resolve(msg);
        this.openWaiter = null;
        break;
      case FROM_WORKER.FRAME:
        this.handlers.onFrame(msg);
        break;
      case FROM_WORKER.PROGRESS:
        this.handlers.onProgress(msg);
        break;
      case FROM_WORKER.IDLE:
        this.handlers.onIdle?.(msg);
        break;
      case FROM_WORKER.GPU_LOST:
        this.handlers.onGpuLost?.(msg.message);
        break;
      case FROM_WORKER.REPLY: {
        const waiter = this.replies.get(msg.id);
        this.replies.delete(msg.id);
        waiter?.resolve(msg.value);
        break;
      }
      case FROM_WORKER.ERROR: {
        if (msg.open && this.openWaiter) {
          this.openWaiter.reject(new Error(msg.message));
          this.openWaiter = null;
        } else if (this.replies.has(msg.id)) {
          this.replies.get(msg.id).reject(new Error(msg.message));
          this.replies.delete(msg.id);
        } else {
          this.handlers.onError(msg.message, msg.id);
        }
        break;
      }
    }
  }

  /** Hands the GPU path its canvas (an OffscreenCanvas); once, before opening. */
  setCanvas(canvas) {
    this.worker.postMessage(canvasMessage(canvas), [canvas]);
  }

  /** Opens a scene by URL or files; resolves with `{info, backends, gpu, choice}`. */
  open(message, transfer = []) {
    return new Promise((resolve, reject) => {
      this.openWaiter = { resolve, reject };
      this.worker.postMessage(message, transfer);
    });
  }

  /** `gpu`: whether to set up the GPU path too; `choose`: whether the worker picks the
   * faster renderer (it times a small frame on each when the GPU is a real one, or always
   * with `trial`). */
  openUrl(url, gpu = false, { choose = false, trial = false } = {}) {
    return this.open(openUrlMessage(url, gpu, { choose, trial }));
  }

  openFiles(files, paths, gpu = false, { choose = false, trial = false } = {}) {
    return this.open(openFilesMessage(files, paths, gpu, { choose, trial }));
  }

  /** Calls a Viewer query in the worker; resolves with its value. */
  call(method, ...args) {
    const id = this.nextId++;
    return new Promise((resolve, reject) => {
      this.replies.set(id, { resolve, reject });
      this.worker.postMessage(callMessage(id, method, args));
    });
  }

  /** Asks for a frame; returns its id. A newer request replaces an older one. */
  render(request) {
    const id = this.nextId++;
    this.worker.postMessage(renderMessage(request, id));
    return id;
  }

  /** Starts loading a time step in the background (playback look-ahead). */
  prefetch(timeStep) {
    this.worker.postMessage(prefetchMessage(timeStep));
  }
}
