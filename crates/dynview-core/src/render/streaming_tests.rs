//! The streaming renderers on a small synthetic scene (a textured plane seen by three input
//! cameras, its sparse points on it): the level-at-a-time renderer gives coarse levels first,
//! finishes with the very frame of the whole-frame renderer, and uses the previous frame only
//! when streaming and until a jump; and the background plates keep what stands in front of the
//! static scene in the inputs off it.

use std::rc::Rc;

use glam::{DVec2, DVec3};

use super::*;
use crate::camera::{Camera, Intrinsics, Rigid3};
use crate::display::DisplayMode;
use crate::points::PointCloud;
use crate::raster::{Raster, RgbRaster};

const WIDTH_PX: u32 = 64;
const HEIGHT_PX: u32 = 48;

/// A camera at `eye_world` looking at the world origin, where the plane is.
fn camera_looking_at_origin(eye_world: DVec3) -> Camera {
    Camera {
        intrinsics: Intrinsics::from_vertical_fov(50f64.to_radians(), WIDTH_PX, HEIGHT_PX),
        camera_from_world: Rigid3::camera_from_world_looking_at(eye_world, DVec3::ZERO, DVec3::Y),
        width_px: WIDTH_PX,
        height_px: HEIGHT_PX,
    }
}

/// The plane's color at world `(x, y, 0)`.
fn texture(x: f64, y: f64) -> [f32; 3] {
    [(0.5 + 0.4 * (5.0 * x).sin()) as f32, (0.5 + 0.4 * (4.0 * y).cos()) as f32, 0.5]
}

/// What `camera` sees of the plane `z = 0` (gray where a ray misses it).
fn view_of_plane(camera: &Camera) -> RgbRaster {
    let center_world = camera.center_world();
    let (width, height) = (camera.width_px as usize, camera.height_px as usize);
    let data = (0..width * height)
        .map(|i| {
            let pixel = DVec2::new((i % width) as f64, (i / width) as f64);
            let ray_world = camera.unproject_world(pixel, 1.0) - center_world;
            let distance = -center_world.z / ray_world.z;
            if distance > 0.0 {
                let hit_world = center_world + distance * ray_world;
                texture(hit_world.x, hit_world.y)
            } else {
                [0.5; 3]
            }
        })
        .collect();
    Raster::from_vec(width, height, data).unwrap()
}

/// Three input views of the plane and a grid of points on it.
fn inputs(levels: usize) -> Rc<TimeStepInputs> {
    let eyes_world = [DVec3::new(-0.6, 0.1, -4.0), DVec3::new(0.6, -0.1, -4.0), DVec3::new(0.0, 0.5, -4.2)];
    let views = eyes_world
        .iter()
        .map(|&eye| {
            let camera = camera_looking_at_origin(eye);
            InputView::new(camera, view_of_plane(&camera), levels)
        })
        .collect();
    let mut cloud = PointCloud::default();
    for j in -15..=15 {
        for i in -15..=15 {
            let (x, y) = (f64::from(i) * 0.1, f64::from(j) * 0.1);
            cloud.positions_world.push([x as f32, y as f32, 0.0]);
            cloud.colors.push(texture(x, y).map(|c| (c * 255.0).round() as u8));
        }
    }
    Rc::new(TimeStepInputs { cloud, views, static_points: 0 })
}

#[test]
fn with_plates_what_stands_in_front_of_the_static_scene_in_the_inputs_is_not_painted_onto_it() {
    let levels = RenderParams::default().levels;
    let clean = inputs(levels);
    // Something dark stands in front of the plane's centre, seen by two of the three views and
    // out of the novel view (no point of it): they show it where the plane's centre is.
    let mut occluded = (*clean).clone();
    for view in occluded.views.iter_mut().take(2) {
        let (centre, _) = view.camera.project_world(DVec3::ZERO).expect("in front");
        let mut frame = view.levels[0].clone();
        for (i, p) in frame.data.iter_mut().enumerate() {
            if DVec2::new((i % frame.width) as f64, (i / frame.width) as f64).distance(centre) < 8.0 {
                *p = [0.05; 3];
            }
        }
        *view = InputView::new(view.camera, frame, levels);
    }
    // The same, each view with its background plate (what it shows without the dark thing), and
    // every point the static scene's.
    let mut with_plates = occluded.clone();
    for (view, clean) in with_plates.views.iter_mut().zip(&clean.views) {
        *view = view.clone().with_plate(clean.levels[0].clone());
    }
    with_plates.static_points = with_plates.cloud.len();
    let novel = camera_looking_at_origin(DVec3::new(0.0, 0.0, -3.8));
    let truth = view_of_plane(&novel);
    let params = RenderParams::default();
    let error = |inputs: &TimeStepInputs| {
        let out = render_frame(&params, &novel, inputs, None, &mut RenderHooks::default()).unwrap();
        // Mean absolute error over the centre, where the dark thing lands.
        let (w, h) = (novel.width_px as usize, novel.height_px as usize);
        let centre: Vec<usize> =
            (0..w * h).filter(|&i| ((i % w) as f64 - w as f64 / 2.0).hypot((i / w) as f64 - h as f64 / 2.0) < 6.0).collect();
        centre.iter().map(|&i| (0..3).map(|k| (out.color.data[i][k] - truth.data[i][k]).abs()).sum::<f32>() / 3.0).sum::<f32>()
            / centre.len() as f32
    };
    let (without, with) = (error(&occluded), error(&with_plates));
    assert!(without > 0.1, "the dark thing shows without plates (mean error {without})");
    assert!(with < 0.02, "with plates the plane shows (mean error {with}, {without} without)");
}

/// The virtual camera of frame `i` of a short pan.
fn virtual_camera(i: u32) -> Camera {
    camera_looking_at_origin(DVec3::new(0.1 + 0.05 * f64::from(i), 0.2, -3.8))
}

fn request(i: u32, inputs: &Rc<TimeStepInputs>, streaming: bool) -> CpuStreamRequest {
    CpuStreamRequest { camera: virtual_camera(i), time_step: i, inputs: inputs.clone(), streaming }
}

/// Steps `renderer` to the end of its frame; returns the widths of the levels, in order.
fn finish(renderer: &mut CpuStreamingRenderer) -> Vec<usize> {
    let mut widths = Vec::new();
    loop {
        let progress = renderer.step(&mut RenderHooks::default()).unwrap();
        widths.push(progress.width_px);
        if progress.done {
            return widths;
        }
    }
}

#[test]
fn levels_come_coarse_to_fine_and_end_in_the_frame_of_the_whole_frame_renderer() {
    let params = RenderParams::default();
    let inputs = inputs(params.levels);
    let mut by_level = CpuStreamingRenderer::new();
    let mut whole = StreamingRenderer::new();
    for i in 0..2 {
        by_level.begin(&params, request(i, &inputs, true)).unwrap();
        assert!(by_level.is_rendering() && by_level.preview().is_none());
        let mut widths = Vec::new();
        loop {
            let progress = by_level.step(&mut RenderHooks::default()).unwrap();
            widths.push(progress.width_px);
            let picture = by_level.picture(DisplayMode::Depth).unwrap();
            assert_eq!((picture.width, picture.height), (progress.width_px, progress.height_px));
            if progress.done {
                assert_eq!(progress.temporal_used, i > 0, "frame {i}");
                break;
            }
            assert_eq!(by_level.preview().unwrap().level, progress.level);
        }
        assert_eq!(widths, [8, 16, 32, 64], "frame {i}");
        assert!(!by_level.is_rendering());
        assert!(matches!(by_level.step(&mut RenderHooks::default()), Err(RenderError::Cancelled)));

        let expected = whole.render(&params, &virtual_camera(i), &inputs, &mut RenderHooks::default()).unwrap();
        let finished = by_level.finished().unwrap();
        let finest = &finished.frame.levels[0];
        assert_eq!(finest.color, expected.color, "frame {i}: color");
        assert_eq!(finest.depth, expected.depth, "frame {i}: depth");
        assert_eq!(finished.view_weight, expected.view_weight, "frame {i}: view weights");
        assert_eq!(finished.views_used, expected.views_used.len());
        assert_eq!((finished.time_step, finished.temporal_used), (i, expected.temporal_used));
        assert_eq!(finished.frame.levels.len(), params.levels);
    }
}

#[test]
fn the_previous_frame_is_used_only_when_streaming_and_until_a_jump() {
    let params = RenderParams::default();
    let inputs = inputs(params.levels);
    let mut renderer = CpuStreamingRenderer::new();
    assert!(!renderer.has_previous());
    for (streaming, jump, temporal_used) in [(true, false, false), (true, false, true), (false, false, false), (true, true, false)] {
        if jump {
            renderer.jump();
            assert!(!renderer.has_previous());
        }
        renderer.begin(&params, request(1, &inputs, streaming)).unwrap();
        finish(&mut renderer);
        assert_eq!(renderer.finished().unwrap().temporal_used, temporal_used, "streaming {streaming}, jump {jump}");
        assert!(renderer.has_previous());
    }
}

#[test]
fn pictures_show_the_level_in_progress_then_the_finished_frame() {
    let params = RenderParams::default();
    let inputs = inputs(params.levels);
    let mut renderer = CpuStreamingRenderer::new();
    assert!(renderer.picture(DisplayMode::Color).is_none(), "nothing rendered yet");
    renderer.begin(&params, request(0, &inputs, false)).unwrap();
    assert!(renderer.picture(DisplayMode::Color).is_none(), "no level finished yet");
    renderer.step(&mut RenderHooks::default()).unwrap();
    let preview = renderer.preview().unwrap();
    assert_eq!(&renderer.picture(DisplayMode::Color).unwrap(), preview.color);
    let weights = renderer.picture(DisplayMode::Weights).unwrap();
    assert!(weights.data.iter().all(|&px| px == [0.0; 3]), "a level in progress has no view weights");
    finish(&mut renderer);
    let finished = renderer.finished().unwrap();
    assert_eq!(renderer.picture(DisplayMode::Color).unwrap(), finished.frame.levels[0].color);
    let expected = crate::display::colorize_weights(&finished.view_weight, finished.views_used);
    assert_eq!(renderer.picture(DisplayMode::Weights).unwrap(), expected);
    // A frame in progress is shown over the finished one, once it has a level.
    renderer.begin(&params, request(1, &inputs, true)).unwrap();
    assert_eq!(renderer.picture(DisplayMode::Color).unwrap().width, WIDTH_PX as usize);
    renderer.step(&mut RenderHooks::default()).unwrap();
    assert_eq!(renderer.picture(DisplayMode::Color).unwrap().width, 8);
}

#[test]
fn a_refused_request_drops_the_render_in_progress_and_keeps_the_finished_frame() {
    let params = RenderParams::default();
    let inputs = inputs(params.levels);
    let mut renderer = CpuStreamingRenderer::new();
    renderer.begin(&params, request(0, &inputs, false)).unwrap();
    finish(&mut renderer);
    renderer.begin(&params, request(1, &inputs, true)).unwrap();
    renderer.step(&mut RenderHooks::default()).unwrap();
    let mut empty = request(2, &inputs, true);
    empty.camera.width_px = 0;
    assert!(matches!(renderer.begin(&params, empty), Err(RenderError::OutputSize { width: 0, .. })));
    assert!(!renderer.is_rendering());
    assert_eq!(renderer.finished().unwrap().time_step, 0);
    renderer.begin(&params, request(1, &inputs, true)).unwrap();
    renderer.cancel();
    assert!(!renderer.is_rendering() && renderer.has_previous());
    assert!(matches!(renderer.step(&mut RenderHooks::default()), Err(RenderError::Cancelled)));
}

#[test]
fn views_are_ranked_with_rank_sigma_and_not_with_the_colour_tolerance() {
    // Nearer to input 0, but turned more from it than from input 2: a narrow angular
    // tolerance ranks input 2 first, a wide one input 0 (the distance then counts more).
    let camera = camera_looking_at_origin(DVec3::new(-0.3, 0.4, -3.5));
    let inputs = inputs(RenderParams::default().levels);
    let best_view = |params: RenderParams| {
        let params = RenderParams { views: 1, method: Method::Blend, ..params };
        StreamingRenderer::new().render(&params, &camera, &inputs, &mut RenderHooks::default()).unwrap().views_used
    };
    let narrow = RenderParams { rank_sigma: 0.075, ..RenderParams::default() };
    let wide = RenderParams { rank_sigma: 0.3, ..RenderParams::default() };
    assert_eq!(best_view(narrow.clone()), [2]);
    assert_eq!(best_view(wide.clone()), [0]);
    for sigma in [0.02, 0.3] {
        assert_eq!(best_view(RenderParams { sigma, ..narrow.clone() }), [2], "colour tolerance {sigma}");
        assert_eq!(best_view(RenderParams { sigma, ..wide.clone() }), [0], "colour tolerance {sigma}");
    }
}
