//! A whole frame from a sparse cloud, where the plane prior (`RenderParams::lambda_plane`) does
//! the work: the GPU renders what the CPU renders, and the plane brings the depth where no
//! point is near toward the truth.

use dynview_core::camera::{Camera, Intrinsics, Rigid3};
use dynview_core::raster::{Raster, RgbRaster};
use dynview_core::render::{InputView, Method, RenderHooks, RenderParams, TimeStepInputs, render_frame};
use dynview_core::scene::PointCloud;
use dynview_gpu::{GpuContext, GpuFrame, GpuInputs, GpuRenderer, wgpu};
use glam::DVec3;

/// The scene: a floor at y = -1 and a wall at z = -3, both smoothly textured.
fn hit(center: DVec3, direction: DVec3) -> Option<DVec3> {
    let floor = (direction.y < 0.0).then(|| (-1.0 - center.y) / direction.y);
    let wall = (direction.z < 0.0).then(|| (-3.0 - center.z) / direction.z);
    let t = match (floor, wall) {
        (Some(a), Some(b)) => a.min(b),
        (a, b) => a.or(b)?,
    };
    Some(center + direction * t)
}

fn texture(p: DVec3) -> [f32; 3] {
    let (u, v) = (p.x, if p.y <= -0.999 { p.z } else { p.y });
    [(0.5 + 0.35 * (4.0 * u).sin()) as f32, (0.5 + 0.35 * (3.0 * v + 1.0).sin()) as f32, (0.5 + 0.25 * (2.0 * u + 3.0 * v).cos()) as f32]
}

fn camera(eye: DVec3, w: u32, h: u32) -> Camera {
    Camera {
        intrinsics: Intrinsics::from_vertical_fov(0.9, w, h),
        camera_from_world: Rigid3::camera_from_world_looking_at(eye, DVec3::new(0.0, -0.5, 0.0), DVec3::Y),
        width_px: w,
        height_px: h,
    }
}

/// The true depth and color the camera sees.
fn ray_cast(camera: &Camera) -> (Vec<f32>, RgbRaster) {
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    let center = camera.center_world();
    let mut depth = vec![0.0f32; w * h];
    let mut color = Raster::filled(w, h, [0.0f32; 3]);
    for (i, (d, c)) in depth.iter_mut().zip(color.data.iter_mut()).enumerate() {
        let pixel = glam::DVec2::new((i % w) as f64, (i / w) as f64);
        let direction = camera.unproject_world(pixel, 1.0) - center;
        if let Some(p) = hit(center, direction) {
            *d = camera.camera_from_world.transform_point(p).z as f32;
            *c = texture(p);
        }
    }
    (depth, color)
}

/// 32 points on the floor and 16 on the wall, all on the left of the picture: the right has
/// none. The floor is the dominant plane.
fn sparse_cloud() -> PointCloud {
    let mut cloud = PointCloud::default();
    for k in 0..48 {
        let (a, b) = (f64::from(k % 8), f64::from(k / 8 % 4));
        let p = if k < 32 { DVec3::new(-1.6 + 0.15 * a, -1.0, -1.5 + 0.5 * b) } else { DVec3::new(-1.8 + 0.15 * a, -0.8 + 0.3 * b, -3.0) };
        let c = texture(p).map(|v| (v * 255.0).round() as u8);
        cloud.positions_world.push([p.x as f32, p.y as f32, p.z as f32]);
        cloud.colors.push(c);
    }
    cloud
}

fn psnr(a: &[f32], b: &[f32]) -> f64 {
    let mse = a.iter().zip(b).map(|(x, y)| f64::from(x - y).powi(2)).sum::<f64>() / a.len() as f64;
    10.0 * (1.0 / mse.max(1e-20)).log10()
}

/// Three views of the scene at `w x h` with the sparse cloud.
fn inputs(w: u32, h: u32) -> TimeStepInputs {
    let views: Vec<InputView> = [DVec3::new(-1.0, 0.3, 4.0), DVec3::new(1.2, 0.4, 4.2), DVec3::new(0.1, 1.0, 4.5)]
        .into_iter()
        .map(|eye| {
            let cam = camera(eye, w, h);
            InputView::new(cam, ray_cast(&cam).1, 4)
        })
        .collect();
    TimeStepInputs { cloud: sparse_cloud(), views, static_points: 0 }
}

#[test]
fn a_sparse_frame_with_the_plane_matches_on_the_gpu_and_nears_the_truth() {
    let (w, h) = (96u32, 64u32);
    let inputs = inputs(w, h);
    let novel = camera(DVec3::new(0.3, 0.5, 4.3), w, h);
    let (true_depth, _) = ray_cast(&novel);
    let on_floor: Vec<bool> = (0..true_depth.len())
        .map(|i| {
            let pixel = glam::DVec2::new((i % w as usize) as f64, (i / w as usize) as f64);
            true_depth[i] > 0.0 && novel.unproject_world(pixel, f64::from(true_depth[i])).y < -0.999
        })
        .collect();
    let params = RenderParams { method: Method::NoTemporal, ..RenderParams::default() };
    let cpu = render_frame(&params, &novel, &inputs, None, &mut RenderHooks::default()).unwrap();

    // The GPU renders the same frame.
    let ctx = GpuContext::new_blocking().unwrap_or_else(|e| panic!("{e}"));
    let renderer = GpuRenderer::new(&ctx);
    let gpu = renderer.render(&ctx, &params, &novel, &GpuInputs::upload(&ctx, &inputs).unwrap(), None).unwrap();
    let gpu_color = gpu.color().download(&ctx).unwrap();
    let gpu_depth = gpu.depth().download(&ctx).unwrap();
    let color_db = psnr(&gpu_color, cpu.color.data.as_flattened());
    let scale = cpu.depth.data.iter().copied().fold(0.0f32, f32::max);
    let relative = |d: &[f32]| d.iter().map(|v| v / scale).collect::<Vec<_>>();
    let depth_db = psnr(&relative(&gpu_depth), &relative(&cpu.depth.data));
    eprintln!("GPU against CPU: color {color_db:.1} dB, depth {depth_db:.1} dB");
    assert!(color_db >= 45.0 && depth_db >= 45.0, "color {color_db:.1} dB, depth {depth_db:.1} dB");

    // Without the plane the depth far from the points is the membrane's guess; with it, the
    // floor on the right (no point there) is nearer the truth. (Where the truth is not the
    // dominant plane, the wall, the plane is no better a guess than the membrane's.)
    let without = RenderParams { lambda_plane: 0.0, ..params.clone() };
    let membrane = render_frame(&without, &novel, &inputs, None, &mut RenderHooks::default()).unwrap();
    let right_half_error = |depth: &[f32]| {
        let errors: Vec<f64> = (0..depth.len())
            .filter(|&i| i % w as usize >= w as usize / 2 && true_depth[i] > 0.0 && on_floor[i])
            .map(|i| f64::from((depth[i] - true_depth[i]).abs() / true_depth[i]))
            .collect();
        errors.iter().sum::<f64>() / errors.len() as f64
    };
    let (with_plane, without_plane) = (right_half_error(&cpu.depth.data), right_half_error(&membrane.depth.data));
    eprintln!("mean relative depth error on the floor on the right: {with_plane:.4} with the plane, {without_plane:.4} without");
    assert!(with_plane < 0.7 * without_plane, "{with_plane:.4} against {without_plane:.4}");
}

/// Color and depth of a GPU frame, and its view weight.
fn download(ctx: &GpuContext, frame: &GpuFrame) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let weight = frame.view_weight.as_ref().expect("the finest level's view weight").download(ctx).unwrap();
    (frame.color().download(ctx).unwrap(), frame.depth().download(ctx).unwrap(), weight)
}

#[test]
fn frames_render_the_same_where_each_view_needs_a_buffer_of_its_own() {
    let (w, h) = (96u32, 64u32);
    let inputs = inputs(w, h);
    let first = camera(DVec3::new(0.3, 0.5, 4.3), w, h);
    let second = camera(DVec3::new(0.35, 0.5, 4.3), w, h);
    let params = RenderParams::default();
    assert_eq!(params.method, Method::Full);
    // One RGB view's warp is 96 x 64 x 12 bytes = 73728; the largest single image (RGBA at
    // 96 x 64) is 98304. A binding of 100000 bytes holds one view's warp, not two.
    let small = GpuContext::with_limits_blocking(wgpu::Limits { max_storage_buffer_binding_size: 100_000, ..wgpu::Limits::default() })
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(dynview_gpu::ViewChunks::for_device(&small, w as usize, h as usize, inputs.views.len()).unwrap().per_chunk, 1);
    let ctx = GpuContext::new_blocking().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(dynview_gpu::ViewChunks::for_device(&ctx, w as usize, h as usize, inputs.views.len()).unwrap().per_chunk, 3);
    let frames = |ctx: &GpuContext| {
        let renderer = GpuRenderer::new(ctx);
        let uploaded = GpuInputs::upload(ctx, &inputs).unwrap();
        let a = renderer.render(ctx, &params, &first, &uploaded, None).unwrap();
        let b = renderer.render(ctx, &params, &second, &uploaded, Some(&a)).unwrap();
        (download(ctx, &a), download(ctx, &b))
    };
    let (split, whole) = (frames(&small), frames(&ctx));
    // The CPU renders the same two frames.
    let cpu_a = render_frame(&params, &first, &inputs, None, &mut RenderHooks::default()).unwrap();
    let previous = cpu_a.clone().into_previous(first);
    let cpu_b = render_frame(&params, &second, &inputs, Some(&previous), &mut RenderHooks::default()).unwrap();
    for (name, (split, whole), cpu) in [("first", (&split.0, &whole.0), &cpu_a), ("second", (&split.1, &whole.1), &cpu_b)] {
        let scale = cpu.depth.data.iter().copied().fold(0.0f32, f32::max);
        let relative = |d: &[f32]| d.iter().map(|v| v / scale).collect::<Vec<_>>();
        let (color_db, depth_db) = (psnr(&split.0, &whole.0), psnr(&relative(&split.1), &relative(&whole.1)));
        let weight_db = psnr(&split.2.iter().map(|v| v / 3.0).collect::<Vec<_>>(), &whole.2.iter().map(|v| v / 3.0).collect::<Vec<_>>());
        eprintln!("{name} frame, views split against whole: color {color_db:.1} dB, depth {depth_db:.1} dB, view weight {weight_db:.1} dB");
        assert!(color_db >= 80.0 && depth_db >= 80.0 && weight_db >= 80.0, "{name}: {color_db:.1} / {depth_db:.1} / {weight_db:.1} dB");
        let cpu_db = psnr(&split.0, cpu.color.data.as_flattened());
        let weight_cpu_db =
            psnr(&split.2.iter().map(|v| v / 3.0).collect::<Vec<_>>(), &cpu.view_weight.data.iter().map(|v| v / 3.0).collect::<Vec<_>>());
        eprintln!("{name} frame, views split against the CPU: color {cpu_db:.1} dB, view weight {weight_cpu_db:.1} dB");
        assert!(cpu_db >= 45.0 && weight_cpu_db >= 45.0, "{name}: {cpu_db:.1} / {weight_cpu_db:.1} dB against the CPU");
    }
}

#[test]
fn a_frame_uploads_only_the_views_it_renders_from_and_renders_as_with_all_uploaded() {
    let (w, h) = (96u32, 64u32);
    let inputs = inputs(w, h);
    let novel = camera(DVec3::new(0.3, 0.5, 4.3), w, h);
    let params = RenderParams { method: Method::NoTemporal, views: 2, ..RenderParams::default() };
    let ctx = GpuContext::new_blocking().unwrap_or_else(|e| panic!("{e}"));
    let renderer = GpuRenderer::new(&ctx);

    // The cloud alone: the frame says which view is missing instead of rendering without it.
    let mut lazy = GpuInputs::upload_cloud(&ctx, &inputs).unwrap();
    assert!(lazy.uploaded_views().is_empty());
    let err = renderer.render(&ctx, &params, &novel, &lazy, None).unwrap_err();
    assert!(err.to_string().contains("not uploaded"), "{err}");

    // The two views the frame ranks first, their coarser levels made on the GPU.
    renderer.upload_views_for(&ctx, &params, &novel, &mut lazy, &inputs).unwrap();
    assert_eq!(lazy.uploaded_views().len(), 2);
    let all = GpuInputs::upload(&ctx, &inputs).unwrap();
    assert_eq!(all.uploaded_views(), vec![0, 1, 2]);
    let from_lazy = renderer.render(&ctx, &params, &novel, &lazy, None).unwrap().color().download(&ctx).unwrap();
    let from_all = renderer.render(&ctx, &params, &novel, &all, None).unwrap().color().download(&ctx).unwrap();
    let diff = from_lazy.iter().zip(&from_all).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    assert!(diff <= 1e-4, "GPU-made pyramids against the host's: max color difference {diff}");

    // Inputs of another time step with another number of views are refused, not mixed in.
    let fewer = TimeStepInputs { views: inputs.views[..1].to_vec(), ..inputs.clone() };
    let far = camera(DVec3::new(-3.0, 0.5, 3.0), w, h);
    assert!(renderer.upload_views_for(&ctx, &params, &far, &mut lazy, &fewer).is_err());
}
