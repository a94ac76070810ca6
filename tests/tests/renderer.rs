//! The renderer on a real (synthetic, ray-traced) frame: energies, residuals, reproduction of
//! an input view, streaming, and every method producing a sane image.

use dynview_core::metrics::psnr;
use dynview_core::render::{Method, RenderHooks, RenderParams, SolveKind, SolveTrace, StreamingRenderer, render_frame};
use dynview_core::scene::ScenePackage;
use dynview_interchange::camera_path::parse_path;
use dynview_tests::{load_rgb, small_event};

/// Relative residual every solve must reach with the default sweep counts: the red-black
/// sweeps start from the previous solution (upsampled across levels), so a few dozen sweeps
/// reduce the residual of the screened Poisson systems well below this.
const RESIDUAL_TOLERANCE: f64 = 0.05;

fn package() -> ScenePackage {
    ScenePackage::open(small_event().join("scene")).unwrap()
}

#[test]
fn energies_decrease_monotonically_and_residuals_are_small() {
    let package = package();
    let params = RenderParams::default();
    let inputs = package.time_step_inputs(1, params.levels).unwrap();
    let path = parse_path(&std::fs::read(small_event().join("camera_path.json")).unwrap(), "camera_path.json", None).unwrap();
    let mut traces: Vec<SolveTrace> = Vec::new();
    let mut hooks = RenderHooks { solve_traces: Some(&mut traces), ..RenderHooks::default() };
    render_frame(&params, &path[1].camera, &inputs, None, &mut hooks).unwrap();
    let expected = (0..params.levels).map(|l| params.outer_iterations_at(l) * 2).sum::<usize>();
    assert_eq!(traces.len(), expected);
    for trace in &traces {
        let sweeps = if trace.kind == SolveKind::Depth { params.depth_sweeps } else { params.color_sweeps };
        assert_eq!(trace.energies.len(), sweeps + 1);
        for pair in trace.energies.windows(2) {
            // f32 sweeps, f64 sums: allow rounding at the 1e-5 relative level.
            assert!(
                pair[1] <= pair[0] * (1.0 + 1e-5),
                "{:?} level {} iteration {}: energy rose {} -> {}",
                trace.kind,
                trace.level,
                trace.iteration,
                pair[0],
                pair[1]
            );
        }
        assert!(trace.energies.last() < trace.energies.first(), "{trace:?}");
        assert!(trace.final_residual < RESIDUAL_TOLERANCE, "{:?} level {}: residual {}", trace.kind, trace.level, trace.final_residual);
    }
}

#[test]
fn rendering_from_an_input_pose_reproduces_the_input_frame() {
    let package = package();
    let params = RenderParams::default();
    let inputs = package.time_step_inputs(2, params.levels).unwrap();
    let camera = package.camera(1, 2).unwrap();
    let frame = package.read_frame(1, 2).unwrap();
    let out = render_frame(&params, &camera, &inputs, None, &mut RenderHooks::default()).unwrap();
    assert_eq!(out.views_used[0], 1, "the coincident camera must rank first");
    let quality = psnr(&out.color, &frame);
    // The three other views agree within sigma and blend in; 34.4 dB measured at 192x108.
    assert!(quality > 33.0, "PSNR {quality:.2} dB against the input frame");
}

#[test]
fn every_method_renders_a_plausible_heldout_view() {
    let package = package();
    let path = parse_path(&std::fs::read(small_event().join("camera_path.json")).unwrap(), "camera_path.json", None).unwrap();
    let truth = load_rgb(&small_event().join("heldout/color/00002.png"));
    let inputs = package.time_step_inputs(2, RenderParams::default().levels).unwrap();
    let mut scores = Vec::new();
    for method in Method::ALL {
        let params = RenderParams { method, ..RenderParams::default() };
        let out = render_frame(&params, &path[2].camera, &inputs, None, &mut RenderHooks::default()).unwrap();
        assert_eq!((out.color.width, out.color.height), (truth.width, truth.height));
        assert!(out.depth.data.iter().all(|d| d.is_finite() && *d > 0.0), "{method:?}: depth must be dense and positive");
        scores.push((method, psnr(&out.color, &truth)));
    }
    for (method, score) in &scores {
        assert!(*score > 18.0, "{method:?}: {score:.2} dB");
    }
    let get = |m: Method| scores.iter().find(|(k, _)| *k == m).map(|(_, s)| *s).unwrap();
    assert!(get(Method::NoTemporal) > get(Method::Splat) + 3.0, "{scores:?}");
    assert!(get(Method::NoTemporal) > get(Method::Blend), "{scores:?}");
}

#[test]
fn streaming_uses_the_previous_frame_and_jump_drops_it() {
    let package = package();
    let params = RenderParams::default();
    let path = parse_path(&std::fs::read(small_event().join("camera_path_static.json")).unwrap(), "p", None).unwrap();
    let mut renderer = StreamingRenderer::new();
    let a = renderer
        .render(&params, &path[0].camera, &package.time_step_inputs(0, params.levels).unwrap(), &mut RenderHooks::default())
        .unwrap();
    assert!(!a.temporal_used);
    let inputs1 = package.time_step_inputs(1, params.levels).unwrap();
    let b = renderer.render(&params, &path[1].camera, &inputs1, &mut RenderHooks::default()).unwrap();
    assert!(b.temporal_used);
    // The temporal term pulls toward the previous frame: the streamed frame is closer to it than
    // a frame rendered without the previous one.
    let alone = render_frame(&params, &path[1].camera, &inputs1, None, &mut RenderHooks::default()).unwrap();
    assert!(psnr(&b.color, &a.color) > psnr(&alone.color, &a.color));
    renderer.jump();
    assert!(!renderer.has_previous());
    let c = renderer.render(&params, &path[1].camera, &inputs1, &mut RenderHooks::default()).unwrap();
    assert!(!c.temporal_used);
    assert_eq!(c.color, alone.color);
}

#[test]
fn progressive_levels_arrive_coarse_to_fine_and_can_cancel() {
    let package = package();
    let params = RenderParams::default();
    let inputs = package.time_step_inputs(0, params.levels).unwrap();
    let camera = package.camera(0, 0).unwrap();
    let mut seen = Vec::new();
    let mut on_level = |p: dynview_core::render::LevelPreview| {
        seen.push((p.level, p.color.width));
        p.level > 2
    };
    let result =
        render_frame(&params, &camera, &inputs, None, &mut RenderHooks { on_level: Some(&mut on_level), ..RenderHooks::default() });
    assert!(matches!(result, Err(dynview_core::render::RenderError::Cancelled)));
    assert_eq!(seen, vec![(3, 24), (2, 48)]);
}

#[test]
fn a_stepped_job_gives_each_level_then_exactly_the_frame_render_frame_gives() {
    use dynview_core::render::{FrameJob, JobStep, PreviousFrame};
    let package = package();
    let params = RenderParams::default();
    let inputs = package.time_step_inputs(1, params.levels).unwrap();
    let camera = package.camera(2, 1).unwrap();
    let whole = render_frame(&params, &camera, &inputs, None, &mut RenderHooks::default()).unwrap();
    let mut job = FrameJob::<_, &PreviousFrame>::new(params.clone(), camera, &inputs, None).unwrap();
    let mut levels = Vec::new();
    let stepped = loop {
        assert_eq!(job.next_level(), Some(params.levels - 1 - levels.len()));
        match job.step(&mut RenderHooks::default()).unwrap() {
            JobStep::Level(level) => {
                assert_eq!(job.preview(level).color.width, camera.width_px as usize >> level);
                levels.push(level);
            }
            JobStep::Done(output) => break output,
        }
    };
    assert_eq!(levels, vec![3, 2, 1]);
    assert_eq!(job.next_level(), None);
    assert!(job.step(&mut RenderHooks::default()).is_err(), "a finished job does no more work");
    assert_eq!(stepped.color, whole.color);
    assert_eq!(stepped.depth, whole.depth);
    assert_eq!(stepped.coarse_levels.len(), 3);
}
