//! The `Viewer` class the page (its worker) drives: open a scene, load time steps, render a
//! view a pyramid level at a time, read pictures, export camera paths.

use std::cell::RefCell;
use std::rc::Rc;

use dynview_core::display::{self, DisplayMode};
use dynview_core::look_at::pivot_distance;
use dynview_core::render::{CpuStreamRequest, CpuStreamingRenderer, RenderHooks, RenderParams, Timings};
use dynview_core::scene::yuv::PlaneLayout;
use dynview_interchange::camera_path::{NerfstudioPath, parse_path};
use js_sys::{Function, Promise};
use serde::{Deserialize, Serialize};
use wasm_bindgen::prelude::*;

use crate::gpu::{GpuRequest, GpuView};
use crate::scene::{LoadStats, RemoteScene};
use crate::source::{ReadError, Source};
use crate::view::{PathView, SceneInfo, View, view_camera};

#[wasm_bindgen]
extern "C" {
    #[wasm_bindgen(js_namespace = performance, js_name = now)]
    fn performance_now() -> f64;
}

fn error(message: impl std::fmt::Display) -> JsError {
    JsError::new(&message.to_string())
}

impl From<ReadError> for JsError {
    fn from(e: ReadError) -> Self {
        error(e)
    }
}

/// A JS-owned ImageData of RGBA bytes (a copy, not a view of wasm memory: it can be
/// transferred to the page).
fn image_data(rgba: &[u8], width: u32, height: u32) -> Result<web_sys::ImageData, JsValue> {
    let pixels = js_sys::Uint8ClampedArray::from(rgba);
    web_sys::ImageData::new_with_js_u8_clamped_array_and_sh(&pixels, width, height)
}

fn parse_mode(mode: &str) -> Result<DisplayMode, JsError> {
    serde_json::from_value(serde_json::Value::String(mode.to_owned()))
        .map_err(|_| error(format!("display mode {mode:?}: use color, depth or weights")))
}

fn to_js<T: Serialize>(value: &T) -> Result<JsValue, JsError> {
    value.serialize(&serde_wasm_bindgen::Serializer::json_compatible()).map_err(error)
}

/// The state of a render after [`Viewer::step`].
#[derive(Serialize)]
struct StepReport {
    /// Level just finished (0 = finest).
    level: usize,
    /// True when the frame is complete.
    done: bool,
    /// Size of the level's picture.
    width: usize,
    height: usize,
    /// Milliseconds since [`Viewer::begin`].
    elapsed_ms: f64,
    /// Whether the temporal terms were used (on completion).
    temporal_used: bool,
}

/// Parameters of one render request.
#[derive(Deserialize)]
struct Request {
    view: View,
    time_step: u32,
    width: u32,
    height: u32,
    /// Streaming (playback): use the previous finished frame for the temporal terms.
    #[serde(default)]
    streaming: bool,
    /// GPU path: a preview while the view moves, at `1 / 2^max_level` of the size (the CPU
    /// path stops after that level instead, which the worker decides).
    #[serde(default)]
    max_level: Option<usize>,
    /// GPU path: what the canvas shows (`color` when left out).
    #[serde(default)]
    mode: Option<DisplayMode>,
}

/// The viewer: an opened scene, render parameters, and the CPU and GPU paths, each with its
/// frame in progress and its last finished frame (the previous frame of streaming playback).
/// All math and rendering state are dynview-core's and dynview-gpu's.
#[wasm_bindgen]
pub struct Viewer {
    scene: Rc<RemoteScene>,
    params: RenderParams,
    /// The CPU path: the frame in progress, a level per [`Viewer::step`], and the last finished.
    cpu: CpuStreamingRenderer,
    /// When the CPU render in progress began (`performance.now()`, milliseconds).
    cpu_started_ms: f64,
    /// Wall time of the CPU path's last finished frame, in milliseconds.
    cpu_wall_ms: f64,
    /// The GPU path, once [`Viewer::enable_gpu`] has set it up.
    gpu: Rc<RefCell<Option<Rc<GpuView>>>>,
}

#[wasm_bindgen]
impl Viewer {
    /// Opens the scene package at `url` (its folder, or its `scene.json`): reads and validates
    /// the manifest and the clouds index. Frames and clouds are read per time step later.
    #[wasm_bindgen(js_name = openUrl)]
    pub async fn open_url(url: String) -> Result<Viewer, JsError> {
        Ok(Self::new(RemoteScene::open(Source::url(&url)).await?))
    }

    /// Opens a scene package from dropped or picked files: `files[i]` is at `paths[i]`
    /// (relative paths; the package root is the folder of the shallowest `scene.json`).
    #[wasm_bindgen(js_name = openFiles)]
    pub async fn open_files(files: Vec<web_sys::File>, paths: Vec<String>) -> Result<Viewer, JsError> {
        if files.len() != paths.len() {
            return Err(error(format!("{} files but {} paths", files.len(), paths.len())));
        }
        let source = Source::files(paths.into_iter().zip(files).collect())?;
        Ok(Self::new(RemoteScene::open(source).await?))
    }

    fn new(scene: RemoteScene) -> Self {
        Self {
            scene: Rc::new(scene),
            params: RenderParams::default(),
            cpu: CpuStreamingRenderer::new(),
            cpu_started_ms: 0.0,
            cpu_wall_ms: 0.0,
            gpu: Rc::default(),
        }
    }

    /// The scene: name, fps, time steps, cameras, bounds, start view.
    pub fn info(&self) -> Result<JsValue, JsError> {
        to_js(&SceneInfo::new(self.scene.manifest()))
    }

    /// The view of input camera `camera` at time step `time_step` (for snapping to it).
    #[wasm_bindgen(js_name = inputView)]
    pub fn input_view(&self, camera: usize, time_step: u32) -> Result<JsValue, JsError> {
        let manifest = self.scene.manifest();
        if camera >= manifest.cameras.len() || time_step >= manifest.time_step_count {
            return Err(error(format!("camera {camera} at time step {time_step} is not in the scene")));
        }
        let cam = manifest.camera_at(camera, time_step);
        to_js(&View::of_camera(&cam, pivot_distance(&manifest.bounds, &cam)))
    }

    /// The render parameters (`RenderParams` as JSON-like object).
    pub fn params(&self) -> Result<JsValue, JsError> {
        to_js(&self.params)
    }

    /// Replaces the render parameters; fields left out keep their defaults. Invalid values
    /// are rejected with the field's name.
    #[wasm_bindgen(js_name = setParams)]
    pub fn set_params(&mut self, params: JsValue) -> Result<(), JsError> {
        let value: serde_json::Value = serde_wasm_bindgen::from_value(params).map_err(|e| error(format!("params: {e}")))?;
        let params: RenderParams = serde_json::from_value(value).map_err(|e| error(format!("params: {e}")))?;
        params.validate().map_err(error)?;
        if params.levels != self.params.levels {
            // Cached pyramids were built for the old depth; the previous frame too.
            self.scene.clear_cache();
            self.cpu.jump();
            if let Some(gpu) = self.gpu.borrow().as_ref() {
                gpu.clear();
            }
        }
        self.params = params;
        Ok(())
    }

    /// Memory budget of decoded time steps, in bytes.
    #[wasm_bindgen(js_name = setCacheBudget)]
    pub fn set_cache_budget(&self, bytes: f64) {
        self.scene.set_cache_budget(bytes.max(0.0) as usize);
    }

    /// Bytes and frames read so far, and bytes held by the cache.
    #[wasm_bindgen(js_name = loadStats)]
    pub fn load_stats(&self) -> Result<JsValue, JsError> {
        #[derive(Serialize)]
        struct Stats {
            #[serde(flatten)]
            read: LoadStats,
            cache_bytes: usize,
        }
        to_js(&Stats { read: self.scene.stats(), cache_bytes: self.scene.cache_used_bytes() })
    }

    /// True when time step `t` is loaded (a render of it can begin at once).
    #[wasm_bindgen(js_name = isLoaded)]
    pub fn is_loaded(&self, t: u32) -> bool {
        self.scene.cached(t).is_some()
    }

    /// Loads time step `t` (its cloud and every camera's frame) into the cache. Resolves when
    /// done; `onProgress(stats, framesDone, framesTotal)` is called as frames arrive.
    #[wasm_bindgen(js_name = loadStep)]
    pub fn load_step(&self, t: u32, on_progress: Option<Function>) -> Promise {
        let scene = self.scene.clone();
        let levels = self.params.levels;
        wasm_bindgen_futures::future_to_promise(async move {
            let progress = |stats: LoadStats, done: u32, total: u32| {
                if let (Some(f), Ok(stats)) = (on_progress.as_ref(), to_js(&stats)) {
                    // A throwing callback must not abort the load.
                    let _ = f.call3(&JsValue::NULL, &stats, &done.into(), &total.into());
                }
            };
            scene.load_step(t, levels, progress).await.map_err(|e| JsValue::from(error(e)))?;
            Ok(JsValue::UNDEFINED)
        })
    }

    /// A video package's compressed frames that show frame `t` of `camera`: resolves with
    /// `{first, chunks: [Uint8Array], keys: [bool]}`, one VP9 frame per step `first..=t`,
    /// starting at the keyframe of `t`, or after `after` when the caller's decoder has just
    /// shown that frame of the same group (`null`/`undefined`: none).
    #[wasm_bindgen(js_name = videoChunks)]
    pub fn video_chunks(&self, camera: usize, t: u32, after: Option<u32>) -> Promise {
        let scene = self.scene.clone();
        wasm_bindgen_futures::future_to_promise(async move {
            let video = scene.video_chunks(camera, t, after).await.map_err(|e| JsValue::from(error(e)))?;
            let out = js_sys::Object::new();
            let chunks = js_sys::Array::new();
            for chunk in &video.chunks {
                chunks.push(&js_sys::Uint8Array::from(chunk.as_slice()));
            }
            let keys: js_sys::Array = video.keys.iter().map(|&k| JsValue::from(k)).collect();
            js_sys::Reflect::set(&out, &"first".into(), &video.first.into())?;
            js_sys::Reflect::set(&out, &"chunks".into(), &chunks)?;
            js_sys::Reflect::set(&out, &"keys".into(), &keys)?;
            Ok(out.into())
        })
    }

    /// Loads step `t` of a video package from its decoded frames, one per camera in order:
    /// `formats[i]` is `"I420"` or `"NV12"` and `planes[i]` that frame's tight planes. Reads
    /// the step's cloud. Resolves when the step is cached.
    #[wasm_bindgen(js_name = loadStepFrames)]
    pub fn load_step_frames(&self, t: u32, formats: Vec<String>, planes: Vec<js_sys::Uint8Array>) -> Promise {
        let scene = self.scene.clone();
        let levels = self.params.levels;
        wasm_bindgen_futures::future_to_promise(async move {
            if formats.len() != planes.len() {
                return Err(error(format!("{} formats for {} frames", formats.len(), planes.len())).into());
            }
            let mut frames = Vec::with_capacity(planes.len());
            for (format, data) in formats.iter().zip(&planes) {
                let layout = match format.as_str() {
                    "I420" => PlaneLayout::I420,
                    "NV12" => PlaneLayout::Nv12,
                    other => return Err(error(format!("decoded frames in format {other:?}: only I420 and NV12 are read")).into()),
                };
                frames.push((layout, data.to_vec()));
            }
            scene.load_step_from_frames(t, levels, frames).await.map_err(|e| JsValue::from(error(e)))?;
            Ok(JsValue::UNDEFINED)
        })
    }

    /// Starts rendering `{view, time_step, width, height, streaming}`; the step must be
    /// loaded. Drops any render in progress. With `streaming`, the last finished frame feeds
    /// the temporal terms (playback); without, none does (a jump).
    pub fn begin(&mut self, request: JsValue) -> Result<(), JsError> {
        let request: Request = serde_wasm_bindgen::from_value(request).map_err(|e| error(format!("render request: {e}")))?;
        let camera = view_camera(&request.view, request.width, request.height).map_err(error)?;
        self.cpu.cancel();
        let inputs = self
            .scene
            .cached(request.time_step)
            .ok_or_else(|| error(format!("time step {} is not loaded: call loadStep({}) first", request.time_step, request.time_step)))?;
        let stream = CpuStreamRequest { camera, time_step: request.time_step, inputs, streaming: request.streaming };
        self.cpu.begin(&self.params, stream).map_err(error)?;
        self.cpu_started_ms = performance_now();
        Ok(())
    }

    /// True while a render is in progress.
    #[wasm_bindgen(js_name = isRendering)]
    pub fn is_rendering(&self) -> bool {
        self.cpu.is_rendering()
    }

    /// Drops the render in progress.
    pub fn cancel(&mut self) {
        self.cpu.cancel();
    }

    /// Forgets the last finished frame: the next streaming render has no temporal terms.
    pub fn jump(&mut self) {
        self.cpu.jump();
        if let Some(gpu) = self.gpu.borrow().as_ref() {
            gpu.jump();
        }
    }

    /// Solves the next pyramid level of the render in progress. Returns `{level, done, width,
    /// height, elapsed_ms, temporal_used}`.
    pub fn step(&mut self) -> Result<JsValue, JsError> {
        if !self.cpu.is_rendering() {
            return Err(error("no render in progress: call begin() first"));
        }
        let clock = performance_now;
        let mut hooks = RenderHooks { clock: Some(&clock), ..RenderHooks::default() };
        let progress = self.cpu.step(&mut hooks).map_err(error)?;
        let elapsed_ms = performance_now() - self.cpu_started_ms;
        if progress.done {
            self.cpu_wall_ms = elapsed_ms;
        }
        to_js(&StepReport {
            level: progress.level,
            done: progress.done,
            width: progress.width_px,
            height: progress.height_px,
            elapsed_ms,
            temporal_used: progress.temporal_used,
        })
    }

    /// Renders `request` to completion (loading nothing: the step must be loaded) and returns
    /// the picture. `onLevel(report)` is called after each coarse level.
    #[wasm_bindgen(js_name = renderNow)]
    pub fn render_now(&mut self, request: JsValue, mode: &str, on_level: Option<Function>) -> Result<web_sys::ImageData, JsError> {
        self.begin(request)?;
        loop {
            let report = self.step()?;
            if !self.cpu.is_rendering() {
                break;
            }
            if let Some(f) = on_level.as_ref() {
                f.call1(&JsValue::NULL, &report).map_err(|e| error(format!("onLevel threw: {e:?}")))?;
            }
        }
        self.picture(mode)
    }

    /// The picture of the render in progress (its last finished level) or else of the last
    /// finished frame, as `mode` = `color`, `depth` or `weights`, at that level's resolution.
    pub fn picture(&self, mode: &str) -> Result<web_sys::ImageData, JsError> {
        let picture = self.cpu.picture(parse_mode(mode)?).ok_or_else(|| error("nothing rendered yet"))?;
        image_data(&display::to_rgba8(&picture), picture.width as u32, picture.height as u32)
            .map_err(|e| error(format!("ImageData: {e:?}")))
    }

    /// Sets up the GPU path: a WebGPU device from the browser, drawing into `canvas`, or, given
    /// none (a browser that cannot present WebGPU canvases), reading each frame's picture back.
    /// Resolves with the adapter's name; rejects (and the CPU path stays) when there is no
    /// adapter.
    #[wasm_bindgen(js_name = enableGpu)]
    pub fn enable_gpu(&self, canvas: Option<web_sys::OffscreenCanvas>) -> Promise {
        let slot = self.gpu.clone();
        wasm_bindgen_futures::future_to_promise(async move {
            let view = GpuView::new(canvas).await.map_err(|e| JsValue::from(error(e)))?;
            let description = view.describe();
            *slot.borrow_mut() = Some(Rc::new(view));
            Ok(description.into())
        })
    }

    /// Renders `{view, time_step, width, height, streaming, max_level, mode}` on the GPU and
    /// draws it into the canvas; the step must be loaded. The work is submitted before this
    /// returns; the promise resolves with `{level, done, width, height, elapsed_ms,
    /// temporal_used}` when the GPU has finished (with `image`, the picture as ImageData, when
    /// there is no canvas), and rejects when the device is lost.
    #[wasm_bindgen(js_name = renderGpu)]
    pub fn render_gpu(&mut self, request: JsValue) -> Result<Promise, JsError> {
        let gpu = self.gpu.borrow().clone().ok_or_else(|| error("the GPU path is not set up: call enableGpu() first"))?;
        let request: Request = serde_wasm_bindgen::from_value(request).map_err(|e| error(format!("render request: {e}")))?;
        let camera = view_camera(&request.view, request.width, request.height).map_err(error)?;
        let inputs = self
            .scene
            .cached(request.time_step)
            .ok_or_else(|| error(format!("time step {} is not loaded: call loadStep({}) first", request.time_step, request.time_step)))?;
        let started_ms = performance_now();
        let preview_level = request.max_level.filter(|&l| l > 0);
        let rendered = gpu
            .render(
                &self.params,
                &GpuRequest {
                    camera,
                    time_step: request.time_step,
                    inputs: &inputs,
                    streaming: request.streaming,
                    preview_level,
                    mode: request.mode.unwrap_or(DisplayMode::Color),
                },
            )
            .map_err(error)?;
        let mode = request.mode.unwrap_or(DisplayMode::Color);
        Ok(wasm_bindgen_futures::future_to_promise(async move {
            let picture = if gpu.presents() { None } else { Some(gpu.picture(mode).await.map_err(|e| JsValue::from(error(e)))?) };
            gpu.ctx.finished().await.map_err(|e| JsValue::from(error(e)))?;
            if let Some(reason) = gpu.lost() {
                return Err(error(reason).into());
            }
            let report = StepReport {
                level: preview_level.unwrap_or(0),
                done: preview_level.is_none(),
                width: rendered.width,
                height: rendered.height,
                elapsed_ms: performance_now() - started_ms,
                temporal_used: rendered.temporal_used,
            };
            let report = to_js(&report).map_err(JsValue::from)?;
            if let Some((width, height, rgba)) = picture {
                js_sys::Reflect::set(&report, &"image".into(), &image_data(&rgba, width, height)?.into())?;
            }
            Ok(report)
        }))
    }

    /// The picture on the GPU's canvas as `mode`, at the frame's own resolution (an
    /// asynchronous read-back, for tests and exports; the frame loop never reads back).
    #[wasm_bindgen(js_name = gpuPicture)]
    pub fn gpu_picture(&self, mode: &str) -> Result<Promise, JsError> {
        let mode = parse_mode(mode)?;
        let gpu = self.gpu.borrow().clone().ok_or_else(|| error("the GPU path is not set up"))?;
        Ok(wasm_bindgen_futures::future_to_promise(async move {
            let (width, height, rgba) = gpu.picture(mode).await.map_err(|e| JsValue::from(error(e)))?;
            image_data(&rgba, width, height).map(JsValue::from)
        }))
    }

    /// Why the GPU path stopped working (device lost, GPU error), or `undefined`.
    #[wasm_bindgen(js_name = gpuLost)]
    pub fn gpu_lost(&self) -> Option<String> {
        self.gpu.borrow().as_ref().and_then(|g| g.lost())
    }

    /// Destroys the GPU device, as a driver reset would (for testing the fallback to the CPU).
    #[wasm_bindgen(js_name = loseGpu)]
    pub fn lose_gpu(&self) {
        if let Some(gpu) = self.gpu.borrow().as_ref() {
            gpu.destroy();
        }
    }

    /// Timings of the last finished frame: `{time_step, wall_ms, temporal_used, timings}` with
    /// per-level, per-stage milliseconds.
    #[wasm_bindgen(js_name = lastFrame)]
    pub fn last_frame(&self) -> Result<JsValue, JsError> {
        #[derive(Serialize)]
        struct Report<'a> {
            time_step: u32,
            wall_ms: f64,
            temporal_used: bool,
            timings: &'a Timings,
        }
        match self.cpu.finished() {
            Some(f) => {
                to_js(&Report { time_step: f.time_step, wall_ms: self.cpu_wall_ms, temporal_used: f.temporal_used, timings: &f.timings })
            }
            None => Ok(JsValue::NULL),
        }
    }

    /// A nerfstudio `camera_path.json` (the format `dynview render` reads) of `keyframes`
    /// (`[{view, time_step}]`) rendered at `width x height`, `fps` frames per second.
    #[wasm_bindgen(js_name = exportCameraPath)]
    pub fn export_camera_path(&self, keyframes: JsValue, width: u32, height: u32, fps: f64) -> Result<String, JsError> {
        #[derive(Deserialize)]
        struct Keyframe {
            view: View,
            time_step: u32,
        }
        let keyframes: Vec<Keyframe> = serde_wasm_bindgen::from_value(keyframes).map_err(|e| error(format!("keyframes: {e}")))?;
        if keyframes.is_empty() {
            return Err(error("keyframes: none recorded"));
        }
        if !(fps.is_finite() && fps > 0.0) {
            return Err(error(format!("fps {fps} must be positive")));
        }
        let last = self.scene.manifest().time_step_count.saturating_sub(1).max(1);
        let frames = keyframes
            .iter()
            .enumerate()
            .map(|(i, k)| {
                let camera = view_camera(&k.view, width, height).map_err(|e| error(format!("keyframes[{i}]: {e}")))?;
                Ok((camera, f64::from(k.time_step.min(last)) / f64::from(last)))
            })
            .collect::<Result<Vec<_>, JsError>>()?;
        serde_json::to_string_pretty(&NerfstudioPath::from_frames(&frames, fps)).map_err(error)
    }

    /// Parses a camera path (nerfstudio `camera_path.json` or dynview's own format) into
    /// `[{view, time_step, width, height}]` for this scene.
    #[wasm_bindgen(js_name = importCameraPath)]
    pub fn import_camera_path(&self, json: &str, file: &str) -> Result<JsValue, JsError> {
        let frames = parse_path(json.as_bytes(), file, None).map_err(error)?;
        let manifest = self.scene.manifest();
        to_js(&frames.iter().map(|f| PathView::new(f, manifest)).collect::<Vec<_>>())
    }
}
