//! The GPU renderer against the CPU renderer on a real (synthetic, ray-traced) event, on
//! whatever adapter wgpu finds (lavapipe in CI): the same frames, without and with the temporal
//! terms, must agree within the stated tolerance.

use dynview_core::RgbRaster;
use dynview_core::display::{DisplayMode, picture, to_rgba8};
use dynview_core::metrics::psnr;
use dynview_core::raster::Raster;
use dynview_core::render::plates::{STATIC_MASK_MAX_PIXELS, static_mask};
use dynview_core::render::{Method, RenderHooks, RenderParams, render_frame};
use dynview_core::scene::ScenePackage;
use dynview_gpu::{FrameDisplay, GpuContext, GpuInputs, GpuRenderer, GpuStreamingRenderer, StreamRequest, SweepKernel, wgpu};
use dynview_interchange::camera_path::parse_path;
use dynview_tests::small_event;

/// PSNR the GPU frame must reach against the CPU frame.
const MIN_PSNR_DB: f64 = 45.0;
/// Largest mean absolute difference per channel (of 1).
const MAX_MEAN_ABS_DIFFERENCE: f64 = 1.0 / 255.0;

fn mean_abs_difference(a: &RgbRaster, b: &RgbRaster) -> f64 {
    let sum: f64 = a.data.iter().zip(&b.data).map(|(x, y)| (0..3).map(|k| f64::from((x[k] - y[k]).abs())).sum::<f64>()).sum();
    sum / (3 * a.data.len()) as f64
}

fn download_rgb(ctx: &GpuContext, frame: &dynview_gpu::GpuFrame) -> RgbRaster {
    frame.color().download_rgb(ctx).unwrap()
}

#[test]
fn gpu_frames_match_cpu_frames_with_and_without_the_temporal_terms() {
    let ctx = GpuContext::new_blocking().unwrap_or_else(|e| panic!("{e}"));
    eprintln!("adapter: {} ({:?})", ctx.adapter_info.name, ctx.adapter_info.backend);
    let package = ScenePackage::open(small_event().join("scene")).unwrap();
    let path = parse_path(&std::fs::read(small_event().join("camera_path.json")).unwrap(), "camera_path.json", None).unwrap();
    // Both sweep kernels, whichever the adapter would get.
    for (kernel, method) in
        [SweepKernel::PerColour, SweepKernel::Tiled].into_iter().flat_map(|k| [(k, Method::NoTemporal), (k, Method::Full)])
    {
        let renderer = GpuRenderer::with_sweep_kernel(&ctx, kernel);
        let params = RenderParams { method, ..RenderParams::default() };
        let mut cpu_previous = None;
        let mut gpu_previous = None;
        for (i, frame) in path.iter().take(2).enumerate() {
            let t = frame.time.time_step(package.time_step_count());
            let inputs = package.time_step_inputs(t, params.levels).unwrap();
            let cpu = render_frame(&params, &frame.camera, &inputs, cpu_previous.as_ref(), &mut RenderHooks::default()).unwrap();
            let gpu_inputs = GpuInputs::upload(&ctx, &inputs).unwrap();
            let gpu = renderer.render(&ctx, &params, &frame.camera, &gpu_inputs, gpu_previous.as_ref()).unwrap();
            let gpu_color = download_rgb(&ctx, &gpu);
            let db = psnr(&gpu_color, &cpu.color);
            let mad = mean_abs_difference(&gpu_color, &cpu.color);
            eprintln!(
                "{kernel:?} {method:?} frame {i} (temporal {}): GPU vs CPU {db:.1} dB, mean abs difference {:.3}/255",
                cpu.temporal_used,
                mad * 255.0
            );
            assert!(db >= MIN_PSNR_DB, "{method:?} frame {i}: GPU vs CPU {db:.1} dB");
            assert!(mad <= MAX_MEAN_ABS_DIFFERENCE, "{method:?} frame {i}: mean abs difference {:.3}/255", mad * 255.0);
            assert_eq!(cpu.temporal_used, method == Method::Full && i > 0);
            if method == Method::Full && i > 0 {
                // The GPU used the previous frame too: without it, its frame differs.
                let alone = download_rgb(&ctx, &renderer.render(&ctx, &params, &frame.camera, &gpu_inputs, None).unwrap());
                let db_alone = psnr(&alone, &gpu_color);
                assert!(db_alone < 60.0, "the temporal terms changed nothing on the GPU ({db_alone:.1} dB)");
            }
            cpu_previous = Some(cpu.into_previous(frame.camera));
            gpu_previous = Some(gpu);
        }
    }
}

#[test]
fn gpu_frames_match_cpu_frames_with_background_plates() {
    let ctx = GpuContext::new_blocking().unwrap_or_else(|e| panic!("{e}"));
    let package = ScenePackage::open(small_event().join("scene")).unwrap();
    let path = parse_path(&std::fs::read(small_event().join("camera_path.json")).unwrap(), "camera_path.json", None).unwrap();
    let frame = &path[0];
    let params = RenderParams::default();
    let plain = package.time_step_inputs(frame.time.time_step(package.time_step_count()), params.levels).unwrap();
    // Plates unlike the frames (colors inverted in the left half), so that using them shows;
    // the cloud's second half taken as the static scene.
    let mut inputs = plain.clone();
    inputs.views = inputs
        .views
        .into_iter()
        .map(|v| {
            let mut plate = v.levels[0].clone();
            let width = plate.width;
            for (i, p) in plate.data.iter_mut().enumerate() {
                if i % width < width / 2 {
                    *p = p.map(|c| 1.0 - c);
                }
            }
            v.with_plate(plate)
        })
        .collect();
    inputs.static_points = inputs.cloud.len() / 2;
    let renderer = GpuRenderer::new(&ctx);
    let cpu = render_frame(&params, &frame.camera, &inputs, None, &mut RenderHooks::default()).unwrap();
    let gpu = download_rgb(&ctx, &renderer.render(&ctx, &params, &frame.camera, &GpuInputs::upload(&ctx, &inputs).unwrap(), None).unwrap());
    let (db, mad) = (psnr(&gpu, &cpu.color), mean_abs_difference(&gpu, &cpu.color));
    eprintln!("with plates: GPU vs CPU {db:.1} dB, mean abs difference {:.3}/255", mad * 255.0);
    assert!(db >= MIN_PSNR_DB, "GPU vs CPU {db:.1} dB");
    assert!(mad <= MAX_MEAN_ABS_DIFFERENCE, "mean abs difference {:.3}/255", mad * 255.0);
    // The default feathers the static mask's edge (frame and plate mixed); a hard edge too
    // matches, and differs from it.
    assert!(params.plate_feather_px > 0);
    let hard = RenderParams { plate_feather_px: 0, ..params.clone() };
    let cpu_hard = render_frame(&hard, &frame.camera, &inputs, None, &mut RenderHooks::default()).unwrap();
    let gpu_hard =
        download_rgb(&ctx, &renderer.render(&ctx, &hard, &frame.camera, &GpuInputs::upload(&ctx, &inputs).unwrap(), None).unwrap());
    let db_hard = psnr(&gpu_hard, &cpu_hard.color);
    eprintln!("with plates, a hard edge: GPU vs CPU {db_hard:.1} dB");
    assert!(db_hard >= MIN_PSNR_DB, "hard edge: GPU vs CPU {db_hard:.1} dB");
    assert!(psnr(&cpu_hard.color, &cpu.color) < 90.0, "feathering changed nothing");
    // A view past `STATIC_MASK_MAX_PIXELS` gets a smaller static mask, sampled alike by both.
    let large = frame.camera.resized(1024, 576);
    let mask = static_mask(&params, &inputs.cloud, inputs.static_points, &large).unwrap();
    assert!(mask.width < 1024 && mask.width * mask.height <= STATIC_MASK_MAX_PIXELS, "{}x{}", mask.width, mask.height);
    let cpu_large = render_frame(&params, &large, &inputs, None, &mut RenderHooks::default()).unwrap();
    let gpu_large = download_rgb(&ctx, &renderer.render(&ctx, &params, &large, &GpuInputs::upload(&ctx, &inputs).unwrap(), None).unwrap());
    let db_large = psnr(&gpu_large, &cpu_large.color);
    eprintln!("with plates, 1024x576 (a smaller static mask): GPU vs CPU {db_large:.1} dB");
    assert!(db_large >= MIN_PSNR_DB, "1024x576: GPU vs CPU {db_large:.1} dB");
    // The plates were used, on both.
    let cpu_plain = render_frame(&params, &frame.camera, &plain, None, &mut RenderHooks::default()).unwrap();
    let gpu_plain =
        download_rgb(&ctx, &renderer.render(&ctx, &params, &frame.camera, &GpuInputs::upload(&ctx, &plain).unwrap(), None).unwrap());
    assert!(psnr(&cpu.color, &cpu_plain.color) < 30.0, "the plates changed nothing on the CPU");
    assert!(psnr(&gpu, &gpu_plain) < 30.0, "the plates changed nothing on the GPU");
}

/// A device, the renderer, the small event's first path camera and time step 0 uploaded.
struct Setup {
    ctx: GpuContext,
    renderer: GpuRenderer,
    camera: dynview_core::Camera,
    params: RenderParams,
    inputs: GpuInputs,
}

fn setup() -> Setup {
    let ctx = GpuContext::new_blocking().unwrap_or_else(|e| panic!("{e}"));
    let renderer = GpuRenderer::new(&ctx);
    let package = ScenePackage::open(small_event().join("scene")).unwrap();
    let path = parse_path(&std::fs::read(small_event().join("camera_path.json")).unwrap(), "camera_path.json", None).unwrap();
    let params = RenderParams::default();
    let inputs = GpuInputs::upload(&ctx, &package.time_step_inputs(0, params.levels).unwrap()).unwrap();
    Setup { ctx, renderer, camera: path[0].camera, params, inputs }
}

#[test]
fn gpu_buffers_are_allocated_once_per_resolution_and_reused() {
    let Setup { ctx, renderer, camera, params, inputs } = setup();
    let mut pooled = Vec::new();
    for _ in 0..3 {
        drop(renderer.render(&ctx, &params, &camera, &inputs, None).unwrap());
        pooled.push(ctx.pooled());
    }
    // Every buffer of the second and third frames came from the pool: it does not grow.
    assert!(pooled[0].0 > 10, "{pooled:?}");
    assert_eq!(pooled[1], pooled[0], "the second frame allocated new buffers");
    assert_eq!(pooled[2], pooled[0], "the third frame allocated new buffers");
}

/// Largest difference of a displayed byte from dynview-core's picture, per display mode: color
/// and weights are exact up to rounding; the depth map's range comes from a 1024-bin histogram
/// on the GPU instead of a sort, which moves colors by a few levels.
#[test]
fn a_frame_is_one_submit_with_shared_passes_and_reused_bind_groups() {
    let Setup { ctx, renderer, camera, params, inputs } = setup();
    let mut per_frame = Vec::new();
    let mut previous: Option<dynview_gpu::GpuFrame> = None;
    for _ in 0..8 {
        let before = ctx.counters();
        let frame = renderer.render(&ctx, &params, &camera, &inputs, previous.as_ref()).unwrap();
        per_frame.push(ctx.counters() - before);
        previous = Some(frame);
    }
    eprintln!("per frame: {per_frame:?}");
    for (i, counts) in per_frame.iter().enumerate() {
        assert_eq!(counts.submits, 1, "frame {i} was submitted {} times", counts.submits);
        assert!(counts.dispatches > 100, "frame {i}: only {} dispatches", counts.dispatches);
        assert!(counts.passes * 10 <= counts.dispatches, "frame {i}: {} passes for {} dispatches", counts.passes, counts.dispatches);
    }
    // Once the pool has settled (which buffers are idle when a frame starts repeats), streaming
    // frames take the same buffers in the same roles: every bind group comes from the cache.
    assert!(per_frame[0].bind_groups_created > 0);
    for (i, counts) in per_frame.iter().enumerate().skip(5) {
        assert_eq!(counts.bind_groups_created, 0, "streaming frame {i} created bind groups: {counts:?}");
    }
}

#[test]
fn long_dispatches_fold_into_rows_within_the_device_limit() {
    // A device that allows only 64 workgroups per dimension: every linear dispatch of the frame
    // (points, pixels, z-buffers, zero fills: hundreds of workgroups of 64) must fold into rows;
    // the 2D kernels (workgroups of 8x8 over at most 336 pixels a side) fit as they are.
    let Setup { ctx, renderer, camera, params, inputs } = setup();
    let frame = download_rgb(&ctx, &renderer.render(&ctx, &params, &camera, &inputs, None).unwrap());
    let limits = wgpu::Limits { max_compute_workgroups_per_dimension: 64, ..wgpu::Limits::default() };
    let small = GpuContext::with_limits_blocking(limits).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(small.device.limits().max_compute_workgroups_per_dimension, 64);
    let package = ScenePackage::open(small_event().join("scene")).unwrap();
    let small_inputs = GpuInputs::upload(&small, &package.time_step_inputs(0, params.levels).unwrap()).unwrap();
    assert!(
        (camera.width_px * camera.height_px).div_ceil(64) > 64 * 4,
        "the frame is too small to need folding: {}x{}",
        camera.width_px,
        camera.height_px
    );
    let folded = download_rgb(&small, &GpuRenderer::new(&small).render(&small, &params, &camera, &small_inputs, None).unwrap());
    let db = psnr(&folded, &frame);
    eprintln!("folded dispatches vs plain: {db:.1} dB");
    assert!(db >= 90.0, "folding the dispatches changed the frame: {db:.1} dB");
}

#[test]
fn a_frame_past_the_storage_limit_is_an_error_naming_the_size_and_the_limit() {
    let limits = wgpu::Limits { max_storage_buffer_binding_size: 1 << 18, ..wgpu::Limits::default() };
    let ctx = GpuContext::with_limits_blocking(limits).unwrap_or_else(|e| panic!("{e}"));
    let renderer = GpuRenderer::new(&ctx);
    let package = ScenePackage::open(small_event().join("scene")).unwrap();
    let path = parse_path(&std::fs::read(small_event().join("camera_path.json")).unwrap(), "camera_path.json", None).unwrap();
    let params = RenderParams::default();
    let inputs = GpuInputs::upload(&ctx, &package.time_step_inputs(0, params.levels).unwrap()).unwrap();
    let error = renderer.render(&ctx, &params, &path[0].camera, &inputs, None).unwrap_err().to_string();
    assert!(error.contains("bytes, the device binds at most 262144"), "{error}");
    assert!(error.contains(&format!("image of {}x", path[0].camera.width_px)), "{error}");
}

#[test]
fn the_gpu_streaming_renderer_keeps_the_previous_frame_and_the_uploaded_steps() {
    let ctx = GpuContext::new_blocking().unwrap_or_else(|e| panic!("{e}"));
    let renderer = GpuRenderer::new(&ctx);
    let mut streaming = GpuStreamingRenderer::new(&ctx, 2);
    let package = ScenePackage::open(small_event().join("scene")).unwrap();
    let path = parse_path(&std::fs::read(small_event().join("camera_path.json")).unwrap(), "camera_path.json", None).unwrap();
    let params = RenderParams::default();
    let steps: Vec<_> = (0..3).map(|t| package.time_step_inputs(t, params.levels).unwrap()).collect();
    let request = |t: usize, streaming: bool, keep: bool| StreamRequest {
        camera: path[t].camera,
        time_step: t as u32,
        inputs: &steps[t],
        streaming,
        keep,
    };
    let (first, temporal) = streaming.render(&ctx, &params, &request(0, true, true)).unwrap();
    assert!(!temporal, "the first frame has no previous frame");
    // A preview is not kept: the next streaming frame still follows the first.
    let (_, temporal) = streaming.render(&ctx, &params, &request(1, true, false)).unwrap();
    assert!(temporal);
    let (second, temporal) = streaming.render(&ctx, &params, &request(1, true, true)).unwrap();
    assert!(temporal && streaming.has_previous());
    let inputs = GpuInputs::upload(&ctx, &steps[1]).unwrap();
    let expected = renderer.render(&ctx, &params, &path[1].camera, &inputs, Some(&first)).unwrap();
    let db = psnr(&download_rgb(&ctx, &second), &download_rgb(&ctx, &expected));
    assert!(db >= 90.0, "the streaming frame is not the frame rendered after the first: {db:.1} dB");
    // Two steps stay uploaded, the least recently used goes first.
    streaming.render(&ctx, &params, &request(2, true, true)).unwrap();
    assert_eq!(streaming.uploaded_steps(), vec![1, 2]);
    streaming.jump();
    let (_, temporal) = streaming.render(&ctx, &params, &request(2, true, true)).unwrap();
    assert!(!temporal, "a jump forgets the previous frame");
}

fn display_tolerance(mode: DisplayMode) -> (u8, f64) {
    match mode {
        DisplayMode::Color | DisplayMode::Weights => (1, 0.0),
        DisplayMode::Depth => (2, 0.1),
    }
}

#[test]
fn the_gpu_display_shows_what_the_cpu_picture_shows() {
    let Setup { ctx, renderer, camera, params, inputs } = setup();
    let frame = renderer.render(&ctx, &params, &camera, &inputs, None).unwrap();
    let color = download_rgb(&ctx, &frame);
    let depth = frame.depth().download(&ctx).unwrap();
    let depth = Raster::from_vec(color.width, color.height, depth).unwrap();
    let weights = frame.view_weight.as_ref().expect("the frame keeps its view weight").download(&ctx).unwrap();
    let weights = Raster::from_vec(color.width, color.height, weights).unwrap();
    for format in [wgpu::TextureFormat::Rgba8Unorm, wgpu::TextureFormat::Bgra8UnormSrgb] {
        let display = FrameDisplay::new(&ctx, format);
        for mode in [DisplayMode::Color, DisplayMode::Depth, DisplayMode::Weights] {
            let (w, h, shown) = pollster::block_on(display.picture(&ctx, &frame, mode)).unwrap();
            assert_eq!((w as usize, h as usize), (color.width, color.height));
            let expected = to_rgba8(&picture(mode, &color, &depth, Some(&weights), frame.views_used));
            let differences: Vec<u8> = shown.iter().zip(&expected).map(|(a, b)| a.abs_diff(*b)).collect();
            let worst = differences.iter().copied().max().unwrap_or(0);
            let beyond_one = 100.0 * differences.iter().filter(|&&d| d > 1).count() as f64 / differences.len() as f64;
            eprintln!("{format:?} {mode:?}: largest difference {worst}/255, {beyond_one:.3}% of bytes off by more than 1");
            let (max_difference, max_percent_beyond_one) = display_tolerance(mode);
            assert!(worst <= max_difference, "{format:?} {mode:?}: a byte differs by {worst}");
            assert!(beyond_one <= max_percent_beyond_one, "{format:?} {mode:?}: {beyond_one:.3}% of bytes off by more than 1");
            let distinct: std::collections::HashSet<&[u8]> = shown.chunks(4).collect();
            assert!(distinct.len() > 16, "{format:?} {mode:?}: a flat picture");
        }
    }
}

#[test]
fn timestamp_queries_time_every_stage_of_every_level_without_changing_the_frame() {
    let Setup { ctx, camera, params, inputs, .. } = setup();
    let (w, h) = (camera.width_px as u64, camera.height_px as u64);
    for kernel in [SweepKernel::PerColour, SweepKernel::Tiled] {
        let renderer = GpuRenderer::with_sweep_kernel(&ctx, kernel);
        let plain = download_rgb(&ctx, &renderer.render(&ctx, &params, &camera, &inputs, None).unwrap());
        assert!(ctx.start_profile(), "the adapter ({}) has no timestamp queries", ctx.adapter_info.name);
        let profiled = download_rgb(&ctx, &renderer.render(&ctx, &params, &camera, &inputs, None).unwrap());
        let stages = ctx.finish_profile().unwrap();
        assert_eq!(plain.data, profiled.data, "{kernel:?}: profiling changed the frame");
        for level in 0..params.levels {
            for stage in ["splat", "push-pull", "warp", "weights", "depth system", "depth solve", "color system", "color solve"] {
                let found = stages.iter().find(|s| s.level == level && s.stage == stage);
                let found = found.unwrap_or_else(|| panic!("{kernel:?}: no time for {stage} at level {level}: {stages:?}"));
                assert!(found.ms.is_finite() && found.ms >= 0.0 && found.passes > 0, "{found:?}");
            }
        }
        let depth_solve = stages.iter().find(|s| s.level == 0 && s.stage == "depth solve").unwrap();
        let iterations = params.outer_iterations_at(0);
        let (passes, per_solve) = match kernel {
            // All half-sweeps (red, black) of a solve are one dispatch call and so one pass;
            // each binds the system (right, down, inv_diag, rhs: 4 floats a pixel) and the
            // depth (1 float a pixel).
            SweepKernel::PerColour => (iterations, 2 * params.depth_sweeps as u64 * 5 * 4 * w * h),
            // Up to 4 half-sweeps a dispatch, an even number of dispatches, each a pass while
            // profiled; each binds the system and the depth before and after (2 floats a pixel).
            SweepKernel::Tiled => {
                let dispatches = (2 * params.depth_sweeps).div_ceil(4).next_multiple_of(2);
                (dispatches * iterations, dispatches as u64 * 6 * 4 * w * h)
            }
        };
        assert_eq!(depth_solve.passes, passes, "{kernel:?}: {depth_solve:?}");
        assert_eq!(depth_solve.bytes_bound, per_solve * iterations as u64, "{kernel:?}: {depth_solve:?}");
        let total: f64 = stages.iter().map(|s| s.ms).sum();
        assert!(total > 0.0, "{stages:?}");
        eprintln!("{kernel:?}: GPU time of a profiled frame: {total:.1} ms in {} passes", stages.iter().map(|s| s.passes).sum::<usize>());
        // Profiling is over: the next frame writes no timestamps.
        drop(renderer.render(&ctx, &params, &camera, &inputs, None).unwrap());
        assert!(ctx.finish_profile().unwrap().is_empty());
    }
}
