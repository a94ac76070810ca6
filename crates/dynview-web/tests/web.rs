//! The wasm API in a real browser (headless Chromium via wasm-bindgen-test-runner): opening a
//! package from files, loading a step, rendering equal to the native renderer, streaming,
//! progressive steps, camera path export and import, errors for a corrupted package, and the
//! GPU path on the browser's WebGPU.
//!
//! The fixture (a small synthetic package, its held-out camera path and the native renders of
//! that path) is made on the host by the build script of `dynview-web-fixture`, so
//! `wasm-pack test --headless --chrome crates/dynview-web` needs no preparation; `cargo xtask
//! test` runs that same command.
#![cfg(target_arch = "wasm32")]

use dynview_core::metrics::psnr;
use dynview_core::raster::RgbRaster;
use dynview_web::Viewer;
use js_sys::{Array, Uint8Array};
use wasm_bindgen::{JsCast, JsValue};
use wasm_bindgen_test::*;

wasm_bindgen_test_configure!(run_in_browser);

/// PSNR the wasm render must reach against the native render of the same frame. The code is
/// the same; `exp`, `powf` and `atan` come from different math libraries (Rust's libm in wasm,
/// glibc natively), which differ in the last bit, and the camera goes through the page's
/// eye/target/up form. Measured: 48.8 dB, i.e. an RMS difference of a third of an 8-bit level.
const MIN_PSNR_VS_NATIVE_DB: f64 = 45.0;
/// Share of pixels whose channels may differ by more than 2 levels of 255.
const MAX_SHARE_OFF_BY_MORE_THAN_2: f64 = 0.002;

fn file(name: &str, bytes: &[u8]) -> web_sys::File {
    let parts = Array::of1(&Uint8Array::from(bytes));
    web_sys::File::new_with_u8_array_sequence(&parts, name).unwrap()
}

fn read(name: &str) -> &'static [u8] {
    dynview_web_fixture::file(name).unwrap_or_else(|| panic!("{name} not in the fixture"))
}

/// Opens the fixture's package as dropped files under `drop/` (as a folder drop gives them),
/// with `edit` applied to the files first.
async fn open_scene(edit: impl Fn(&str, Vec<u8>) -> Vec<u8>) -> Result<Viewer, JsValue> {
    let (mut files, mut paths) = (Vec::new(), Vec::new());
    for (name, bytes) in dynview_web_fixture::FILES {
        if let Some(rel) = name.strip_prefix("scene/") {
            let bytes = edit(rel, bytes.to_vec());
            files.push(file(rel, &bytes));
            paths.push(format!("drop/scene/{rel}"));
        }
    }
    Viewer::open_files(files, paths).await.map_err(JsValue::from)
}

fn png_raster(bytes: &[u8]) -> RgbRaster {
    RgbRaster::from_rgb8(&image::load_from_memory(bytes).unwrap().to_rgb8())
}

fn image_raster(image: &web_sys::ImageData) -> RgbRaster {
    let rgba = image.data().0;
    let rgb: Vec<u8> = rgba.chunks(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    RgbRaster::from_rgb8(&image::RgbImage::from_raw(image.width(), image.height(), rgb).unwrap())
}

async fn wait(promise: js_sys::Promise) -> Result<JsValue, JsValue> {
    wasm_bindgen_futures::JsFuture::from(promise).await
}

fn get(value: &JsValue, key: &str) -> JsValue {
    js_sys::Reflect::get(value, &key.into()).unwrap()
}

/// `{view, time_step, width, height, streaming}` of frame `i` of the fixture's held-out path.
fn path_request(viewer: &Viewer, i: u32, streaming: bool) -> JsValue {
    let frames = viewer.import_camera_path(std::str::from_utf8(read("camera_path.json")).unwrap(), "camera_path.json").unwrap();
    let frame = Array::from(&frames).get(i);
    let request = js_sys::Object::new();
    for key in ["view", "time_step", "width", "height"] {
        js_sys::Reflect::set(&request, &key.into(), &get(&frame, key)).unwrap();
    }
    js_sys::Reflect::set(&request, &"streaming".into(), &streaming.into()).unwrap();
    request.into()
}

#[wasm_bindgen_test]
async fn renders_equal_the_native_renderer_frame_by_frame_with_streaming() {
    let mut viewer = open_scene(|_, b| b).await.unwrap();
    for i in 0..2u32 {
        let request = path_request(&viewer, i, true);
        let t = get(&request, "time_step").as_f64().unwrap() as u32;
        wait(viewer.load_step(t, None)).await.unwrap();
        let image = viewer.render_now(request, "color", None).unwrap();
        let wasm = image_raster(&image);
        let native = png_raster(read(&format!("native/{i:05}.png")));
        assert_eq!((wasm.width, wasm.height), (native.width, native.height));
        let db = psnr(&wasm, &native);
        let off = wasm.data.iter().zip(&native.data).filter(|(a, b)| (0..3).any(|c| (a[c] - b[c]).abs() > 2.5 / 255.0)).count();
        let share = off as f64 / wasm.data.len() as f64;
        web_sys::console::log_1(
            &format!("frame {i}: wasm vs native {db:.1} dB, {:.3}% of pixels off by more than 2/255", 100.0 * share).into(),
        );
        assert!(db > MIN_PSNR_VS_NATIVE_DB, "frame {i}: wasm vs native {db:.1} dB");
        assert!(share < MAX_SHARE_OFF_BY_MORE_THAN_2, "frame {i}: {:.3}% of pixels differ by more than 2/255", 100.0 * share);
        let last = viewer.last_frame().unwrap();
        // Frame 1 follows frame 0: the temporal terms are on, as in `dynview render`.
        assert_eq!(get(&last, "temporal_used").as_bool(), Some(i > 0), "frame {i}");
    }
}

#[wasm_bindgen_test]
async fn steps_give_coarse_levels_first_and_a_jump_drops_the_previous_frame() {
    let mut viewer = open_scene(|_, b| b).await.unwrap();
    wait(viewer.load_step(0, None)).await.unwrap();
    let request = path_request(&viewer, 0, true);
    viewer.begin(request.clone()).unwrap();
    let mut widths = Vec::new();
    loop {
        let report = viewer.step().unwrap();
        widths.push(get(&report, "width").as_f64().unwrap() as u32);
        assert_eq!(viewer.picture("depth").unwrap().width(), *widths.last().unwrap());
        if get(&report, "done").as_bool().unwrap() {
            break;
        }
    }
    assert!(widths.windows(2).all(|w| w[1] == 2 * w[0]), "coarse to fine: {widths:?}");
    assert!(viewer.step().is_err(), "nothing in progress after the last level");
    viewer.render_now(request.clone(), "color", None).unwrap();
    assert_eq!(get(&viewer.last_frame().unwrap(), "temporal_used").as_bool(), Some(true));
    viewer.jump();
    viewer.render_now(request, "weights", None).unwrap();
    assert_eq!(get(&viewer.last_frame().unwrap(), "temporal_used").as_bool(), Some(false));
}

#[wasm_bindgen_test]
async fn rendering_an_unloaded_step_or_a_bad_view_is_a_clear_error() {
    let mut viewer = open_scene(|_, b| b).await.unwrap();
    let request = path_request(&viewer, 0, false);
    let err = viewer.begin(request.clone()).err().map(JsValue::from).unwrap();
    assert!(format!("{err:?}").contains("not loaded"), "{err:?}");
    wait(viewer.load_step(0, None)).await.unwrap();
    js_sys::Reflect::set(&request, &"width".into(), &0.into()).unwrap();
    let err = viewer.begin(request).err().map(JsValue::from).unwrap();
    assert!(format!("{err:?}").contains("render size"), "{err:?}");
    let out_of_range = wait(viewer.load_step(9999, None)).await.unwrap_err();
    assert!(format!("{out_of_range:?}").contains("out of range"), "{out_of_range:?}");
}

#[wasm_bindgen_test]
async fn a_corrupted_package_is_refused_with_the_file_and_field() {
    let bad_magic = open_scene(|name, mut b| {
        if name == "clouds.bin" {
            b[0] = b'X';
        }
        b
    })
    .await
    .err()
    .unwrap();
    assert!(format!("{bad_magic:?}").contains("clouds.bin"), "{bad_magic:?}");
    let bad_json = open_scene(|name, b| if name == "scene.json" { b"{\"format\": 3}".to_vec() } else { b }).await.err().unwrap();
    assert!(format!("{bad_json:?}").contains("scene.json"), "{bad_json:?}");
    let no_manifest = Viewer::open_files(vec![file("x.txt", b"hello")], vec!["x.txt".into()]).await.err().map(JsValue::from).unwrap();
    assert!(format!("{no_manifest:?}").contains("no scene.json"), "{no_manifest:?}");
    // A frame that is not an image: opening works (frames are read per step), loading fails.
    let viewer = open_scene(|name, b| if name.ends_with("00000.jpg") { b"garbage".to_vec() } else { b }).await.unwrap();
    let err = wait(viewer.load_step(0, None)).await.unwrap_err();
    assert!(format!("{err:?}").contains("00000.jpg"), "{err:?}");
}

#[wasm_bindgen_test]
async fn camera_paths_export_in_the_format_dynview_render_reads() {
    let viewer = open_scene(|_, b| b).await.unwrap();
    let frames = viewer.import_camera_path(std::str::from_utf8(read("camera_path.json")).unwrap(), "camera_path.json").unwrap();
    let keyframes = Array::new();
    for f in Array::from(&frames).iter().take(2) {
        let k = js_sys::Object::new();
        js_sys::Reflect::set(&k, &"view".into(), &get(&f, "view")).unwrap();
        js_sys::Reflect::set(&k, &"time_step".into(), &get(&f, "time_step")).unwrap();
        keyframes.push(&k);
    }
    let json = viewer.export_camera_path(keyframes.into(), 320, 180, 30.0).unwrap();
    let parsed = dynview_interchange::camera_path::parse_path(json.as_bytes(), "export", None).unwrap();
    let original = dynview_interchange::camera_path::parse_path(read("camera_path.json"), "fixture", None).unwrap();
    assert_eq!(parsed.len(), 2);
    for (a, b) in parsed.iter().zip(&original) {
        let (ca, cb) = (a.camera.center_world(), b.camera.center_world());
        assert!((ca - cb).length() < 1e-9, "{ca} vs {cb}");
        assert_eq!(a.time.time_step(dynview_web_fixture::FRAMES), b.time.time_step(dynview_web_fixture::FRAMES));
    }
}

/// Resolves after `ms` milliseconds (lets browser callbacks such as device loss run).
async fn sleep_ms(ms: i32) {
    let promise = js_sys::Promise::new(&mut |resolve, _| {
        let set_timeout: js_sys::Function = js_sys::Reflect::get(&js_sys::global(), &"setTimeout".into()).unwrap().unchecked_into();
        set_timeout.call2(&JsValue::NULL, &resolve, &ms.into()).unwrap();
    });
    wait(promise).await.unwrap();
}

/// The GPU path on the browser's WebGPU (SwiftShader in CI): the same frames as the native
/// CPU renderer, within the same tolerance as the wasm CPU path, then a lost device is a clear
/// error. Headless Chromium cannot present WebGPU canvases, so the pictures are read back.
#[wasm_bindgen_test]
async fn the_gpu_path_renders_the_native_frames_in_the_browser_and_reports_a_lost_device() {
    let mut viewer = open_scene(|_, b| b).await.unwrap();
    let name = wait(viewer.enable_gpu(None)).await.expect("a WebGPU adapter (Chromium with --enable-unsafe-webgpu)");
    web_sys::console::log_1(&format!("WebGPU adapter: {name:?}").into());
    for i in 0..2u32 {
        let request = path_request(&viewer, i, true);
        let t = get(&request, "time_step").as_f64().unwrap() as u32;
        wait(viewer.load_step(t, None)).await.unwrap();
        let report = wait(viewer.render_gpu(request).unwrap()).await.unwrap();
        assert_eq!(get(&report, "done").as_bool(), Some(true));
        assert_eq!(get(&report, "temporal_used").as_bool(), Some(i > 0), "frame {i}");
        let image: web_sys::ImageData = get(&report, "image").dyn_into().unwrap();
        let gpu = image_raster(&image);
        let native = png_raster(read(&format!("native/{i:05}.png")));
        assert_eq!((gpu.width, gpu.height), (native.width, native.height));
        let db = psnr(&gpu, &native);
        let off = gpu.data.iter().zip(&native.data).filter(|(a, b)| (0..3).any(|c| (a[c] - b[c]).abs() > 2.5 / 255.0)).count();
        let share = off as f64 / gpu.data.len() as f64;
        web_sys::console::log_1(
            &format!("frame {i}: browser GPU vs native CPU {db:.1} dB, {:.3}% of pixels off by more than 2/255", 100.0 * share).into(),
        );
        assert!(db > MIN_PSNR_VS_NATIVE_DB, "frame {i}: browser GPU vs native CPU {db:.1} dB");
        assert!(share < MAX_SHARE_OFF_BY_MORE_THAN_2, "frame {i}: {:.3}% of pixels differ by more than 2/255", 100.0 * share);
        let again: web_sys::ImageData = wait(viewer.gpu_picture("color").unwrap()).await.unwrap().dyn_into().unwrap();
        assert_eq!(again.data().0, image.data().0, "gpuPicture differs from the frame's picture");
    }
    assert_eq!(viewer.gpu_lost(), None);
    viewer.lose_gpu();
    sleep_ms(100).await;
    let reason = viewer.gpu_lost().expect("the loss is reported");
    assert!(reason.contains("lost"), "{reason}");
    let request = path_request(&viewer, 0, false);
    let refused = match viewer.render_gpu(request) {
        Err(e) => JsValue::from(e),
        Ok(promise) => wait(promise).await.expect_err("a render on a lost device must fail"),
    };
    let message = get(&refused, "message").as_string().unwrap_or_default();
    assert!(message.contains("lost"), "{message}");
}
