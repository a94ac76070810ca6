// Frames of a video package, decoded in the worker with WebCodecs: one VideoDecoder per camera,
// kept between steps so that playback decodes one chunk per frame, and reset to the keyframe
// when the wanted frame is in another group (a scrub). The wasm viewer reads the chunks (one
// byte range per camera) and turns the decoded planes into RGB, exactly as the native side does.

/** How long a decoder may hold a frame back before it is flushed out (ms). */
const OUTPUT_WAIT_MS = 2000;

/** The tight plane layout of `format` at `width x height`, as `copyTo` takes it. */
function tightLayout(format, width, height) {
  const [cw, ch] = [Math.ceil(width / 2), Math.ceil(height / 2)];
  const luma = width * height;
  if (format === "I420") {
    return { bytes: luma + 2 * cw * ch, layout: [{ offset: 0, stride: width }, { offset: luma, stride: cw }, { offset: luma + cw * ch, stride: cw }] };
  }
  if (format === "NV12") return { bytes: luma + 2 * cw * ch, layout: [{ offset: 0, stride: width }, { offset: luma, stride: 2 * cw }] };
  throw new Error(`the video decoder gave frames in ${format}: only I420 and NV12 are read`);
}

/** One camera's decoder and the frame it showed last. */
class CameraDecoder {
  constructor(codec, width, height, name) {
    Object.assign(this, { codec, width, height, name, decoder: null, last: null, waiting: new Map() });
  }

  open() {
    this.decoder?.close?.();
    this.decoder = new VideoDecoder({
      output: (frame) => this.deliver(frame),
      error: (e) => this.fail(new Error(`${this.name}: the video decoder failed: ${e.message || e}`)),
    });
    this.decoder.configure({ codec: this.codec, codedWidth: this.width, codedHeight: this.height });
    this.last = null;
  }

  async deliver(frame) {
    const t = frame.timestamp;
    const wanted = this.waiting.get(t);
    try {
      if (!wanted) return;
      this.waiting.delete(t);
      const { bytes, layout } = tightLayout(frame.format, this.width, this.height);
      const data = new Uint8Array(bytes);
      await frame.copyTo(data, { layout });
      wanted.resolve({ format: frame.format, data });
    } catch (e) {
      wanted?.reject(e);
    } finally {
      frame.close();
    }
  }

  fail(error) {
    for (const w of this.waiting.values()) w.reject(error);
    this.waiting.clear();
    this.decoder = null;
    this.last = null;
  }

  /** The planes of frame `t`: `{format, data}`. `viewer` reads the chunks. */
  async frame(viewer, camera, t) {
    if (!this.decoder || this.decoder.state === "closed") this.open();
    const { first, chunks, keys } = await viewer.videoChunks(camera, t, this.last ?? undefined);
    if (first !== (this.last ?? -2) + 1) {
      // Another group (or a first frame): start over at its keyframe.
      if (!keys[0]) throw new Error(`${this.name}: frame ${first} is not a keyframe`);
      this.decoder.reset();
      this.decoder.configure({ codec: this.codec, codedWidth: this.width, codedHeight: this.height });
    }
    const shown = new Promise((resolve, reject) => this.waiting.set(t, { resolve, reject }));
    chunks.forEach((data, i) => {
      this.decoder.decode(new EncodedVideoChunk({ type: keys[i] ? "key" : "delta", timestamp: first + i, data }));
    });
    this.last = null; // until frame t is out
    // A decoder that holds frames back releases them on flush, after which it wants a
    // keyframe: the next frame starts its group over.
    let flushed = false;
    const timer = setTimeout(() => {
      flushed = true;
      this.decoder?.flush().catch(() => {});
    }, OUTPUT_WAIT_MS);
    try {
      const planes = await shown;
      this.last = flushed ? null : t;
      return planes;
    } finally {
      clearTimeout(timer);
    }
  }
}

/** The decoders of every camera of an opened video package. */
export class VideoFrames {
  constructor(viewer, info) {
    this.viewer = viewer;
    this.cameras = info.cameras.map((c) => new CameraDecoder(info.video_codec, c.width, c.height, `${c.name}.ivf`));
    this.queue = Promise.resolve();
  }

  /** Loads step `t` into the viewer: every camera's frame decoded, then handed over. Steps are
   * decoded one after another (the decoders hold state); cameras in parallel. */
  load(t, progress) {
    const run = async () => {
      if (this.viewer.isLoaded(t)) return;
      if (typeof VideoDecoder === "undefined") throw new Error("this browser has no WebCodecs VideoDecoder: it cannot show a video package");
      let done = 0;
      const frames = await Promise.all(
        this.cameras.map(async (camera, c) => {
          const planes = await camera.frame(this.viewer, c, t);
          progress?.(this.viewer.loadStats(), ++done, this.cameras.length);
          return planes;
        }),
      );
      await this.viewer.loadStepFrames(t, frames.map((f) => f.format), frames.map((f) => f.data));
    };
    const result = this.queue.then(run, run);
    this.queue = result.catch(() => {});
    return result;
  }
}
