//! dynview's WebAssembly API, for the viewer page (used from a Web Worker so the page never
//! freezes). It opens a scene package over HTTP (range requests for the clouds) or from dropped
//! files, loads time steps on demand into a cache with a memory budget, and renders views with
//! [`dynview_core`]'s renderer one pyramid level at a time, so the worker can show coarse levels
//! first and drop stale work; or with [`dynview_gpu`] on the browser's WebGPU, drawing straight
//! into an `OffscreenCanvas` (`enableGpu`, `renderGpu`). It does no math of its own.
//!
//! JS usage (a module worker):
//! ```js
//! import init, { Viewer } from "./pkg/dynview_web.js";
//! await init();
//! const viewer = await Viewer.openUrl("scenes/demo/");
//! const info = viewer.info();
//! await viewer.loadStep(0);
//! const image = viewer.renderNow({ view: info.start_view, time_step: 0, width: 480, height: 270 }, "color");
//! ```

mod gpu;
mod scene;
mod source;
mod view;
mod viewer;

pub use scene::{DEFAULT_CACHE_BUDGET_BYTES, LoadStats, RemoteScene};
pub use source::{ReadError, Source};
pub use view::{PathView, SceneInfo, View};
pub use viewer::Viewer;

use wasm_bindgen::prelude::*;

#[wasm_bindgen]
extern "C" {
    #[wasm_bindgen(js_namespace = console, js_name = error)]
    fn console_error(message: &str);
}

/// Runs when the module is instantiated: panics (bugs, never bad input) go to the console with
/// their message instead of an opaque `unreachable`.
#[wasm_bindgen(start)]
pub fn start() {
    std::panic::set_hook(Box::new(|info| console_error(&format!("dynview-web panicked: {info}"))));
}
