//! The GPU path against the CPU path, on whatever adapter wgpu finds (lavapipe in CI, with
//! validation on), and every shader through naga's validator.

use dynview_core::raster::Rgb;
use dynview_core::render::solve::{DepthTerms, GridSystem};
use dynview_gpu::{GpuContext, GridSolver, SHADERS, SweepKernel};

/// Largest difference allowed between a GPU and a CPU solve after 24 sweeps, relative to the
/// solution's range. Both do the same float operations in the same order; the GPU may fuse a
/// multiply and an add, which changes the last bit.
const MAX_RELATIVE_DIFFERENCE: f32 = 1e-4;

#[test]
fn every_shader_parses_and_validates() {
    for (name, source) in SHADERS {
        let module = naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)));
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
            .validate(&module)
            .unwrap_or_else(|e| panic!("{name}: {e:?}"));
    }
}

/// A deterministic pseudo-random sequence in [0, 1).
fn noise(seed: u32) -> impl FnMut() -> f32 {
    let mut state = seed.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1u32 << 24) as f32
    }
}

fn context() -> GpuContext {
    let ctx = GpuContext::new_blocking().unwrap_or_else(|e| panic!("{e}"));
    eprintln!("adapter: {} ({:?}, {})", ctx.adapter_info.name, ctx.adapter_info.backend, ctx.adapter_info.driver);
    ctx
}

/// A depth system like the renderer's: smoothness weights over 4 decades, sparse attachment on
/// a few pixels, temporal terms on most.
fn depth_terms(width: usize, height: usize) -> DepthTerms {
    let n = width * height;
    let mut r = noise(7);
    DepthTerms {
        width,
        height,
        w_d: (0..n).map(|_| 10f32.powf(-3.0 + 4.0 * r())).collect(),
        attach: (0..n).map(|_| if r() < 0.05 { 1.0 + r() } else { 0.0 }).collect(),
        sparse_depth: (0..n).map(|_| 2.0 + 5.0 * r()).collect(),
        temporal: (0..n).map(|_| if r() < 0.8 { 0.1 * r() } else { 0.0 }).collect(),
        previous_depth: (0..n).map(|_| 2.0 + 5.0 * r()).collect(),
        plane_weight: (0..n).map(|_| if r() < 0.5 { 0.1 * r() } else { 0.0 }).collect(),
        plane_depth: (0..n).map(|_| 2.0 + 5.0 * r()).collect(),
    }
}

fn max_difference(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

#[test]
fn depth_sweeps_on_the_gpu_match_the_cpu() {
    let ctx = context();
    // An odd size, so partial workgroups and tiles and both parities at the borders are
    // exercised.
    let (w, h) = (97, 61);
    let sys = depth_terms(w, h).system();
    let start: Vec<f32> = {
        let mut r = noise(3);
        (0..w * h).map(|_| 2.0 + 5.0 * r()).collect()
    };
    let mut cpu = start.clone();
    let mut scratch = vec![0.0; w * h];
    for _ in 0..24 {
        sys.sweep(&mut cpu, &mut scratch, 1.6);
    }
    for kernel in [SweepKernel::PerColour, SweepKernel::Tiled] {
        let mut gpu = start.clone();
        GridSolver::with_kernel(&ctx, kernel).solve_depth(&ctx, &sys, &mut gpu, 24, 1.6).unwrap();
        let range = 5.0;
        let diff = max_difference(&cpu, &gpu);
        let adapter = &ctx.adapter_info.name;
        assert!(diff <= MAX_RELATIVE_DIFFERENCE * range, "{kernel:?} GPU vs CPU depth after 24 sweeps: max difference {diff} ({adapter})");
        // And the sweeps did something: the solution moved and the residual fell.
        assert!(max_difference(&start, &gpu) > 0.1);
        assert!(sys.relative_residual(&gpu) < sys.relative_residual(&start) * 0.5);
    }
}

#[test]
fn color_sweeps_on_the_gpu_match_the_cpu() {
    let ctx = context();
    let (w, h) = (64, 33);
    let n = w * h;
    let mut r = noise(11);
    let right: Vec<f32> = (0..n).map(|i| if i % w + 1 < w { r() } else { 0.0 }).collect();
    let down: Vec<f32> = (0..n).map(|i| if i + w < n { r() } else { 0.0 }).collect();
    let data: Vec<f32> = (0..n).map(|_| 0.5 + 2.0 * r()).collect();
    let inv_diag: Vec<f32> = (0..n)
        .map(|i| {
            let left = if i % w > 0 { right[i - 1] } else { 0.0 };
            let up = if i >= w { down[i - w] } else { 0.0 };
            1.0 / (right[i] + down[i] + left + up + data[i])
        })
        .collect();
    let rhs: Vec<Rgb> = (0..n).map(|i| [data[i] * r(), data[i] * r(), data[i] * r()]).collect();
    let sys = GridSystem { width: w, height: h, right, down, inv_diag, rhs };
    let start: Vec<Rgb> = (0..n).map(|_| [r(), r(), r()]).collect();
    let mut cpu = start.clone();
    let mut scratch = vec![[0.0; 3]; n];
    for _ in 0..12 {
        sys.sweep(&mut cpu, &mut scratch, 1.6);
    }
    for kernel in [SweepKernel::PerColour, SweepKernel::Tiled] {
        let mut gpu = start.clone();
        GridSolver::with_kernel(&ctx, kernel).solve_color(&ctx, &sys, &mut gpu, 12, 1.6).unwrap();
        let diff = max_difference(bytemuck_flat(&cpu), bytemuck_flat(&gpu));
        assert!(diff <= MAX_RELATIVE_DIFFERENCE, "{kernel:?} GPU vs CPU color after 12 sweeps: max difference {diff}");
        assert!(max_difference(bytemuck_flat(&start), bytemuck_flat(&gpu)) > 0.05);
    }
}

fn bytemuck_flat(v: &[Rgb]) -> &[f32] {
    v.as_flattened()
}

#[test]
fn mismatched_sizes_are_an_error_not_a_panic() {
    let ctx = context();
    let solver = GridSolver::new(&ctx);
    let sys = depth_terms(8, 8).system();
    let mut too_short = vec![0.0; 10];
    let err = solver.solve_depth(&ctx, &sys, &mut too_short, 1, 1.0).unwrap_err();
    assert!(err.to_string().contains("disagree"), "{err}");
}

use dynview_core::raster::Raster;
use dynview_core::render::{pushpull, pyramid};
use dynview_gpu::{GpuImage, ImageKernels};

/// A random RGB image of `w x h`.
fn rgb_image(w: usize, h: usize, seed: u32) -> Raster<Rgb> {
    let mut r = noise(seed);
    Raster { width: w, height: h, data: (0..w * h).map(|_| [r(), r(), r()]).collect() }
}

#[test]
fn pyramid_resampling_on_the_gpu_matches_the_cpu() {
    let ctx = context();
    let kernels = ImageKernels::new(&ctx);
    // Odd sizes: the last row and column of the box filter average what exists.
    let image = rgb_image(75, 43, 5);
    let gpu = GpuImage::upload(&ctx, image.data.as_flattened(), 75, 43, 3).unwrap();
    let down = kernels.downsample(&ctx, &gpu).unwrap();
    let cpu_down = pyramid::downsample(&image);
    assert_eq!((down.width, down.height), (cpu_down.width, cpu_down.height));
    let diff = max_difference(&down.download(&ctx).unwrap(), cpu_down.data.as_flattened());
    assert!(diff <= 1e-6, "downsample: max difference {diff}");
    for (w, h) in [(150, 86), (301, 171), (40, 20)] {
        let up = kernels.upsample(&ctx, &gpu, w, h).unwrap();
        let cpu_up = pyramid::upsample(&image, w, h);
        let diff = max_difference(&up.download(&ctx).unwrap(), cpu_up.data.as_flattened());
        assert!(diff <= 1e-5, "upsample to {w}x{h}: max difference {diff}");
    }
}

#[test]
fn push_pull_on_the_gpu_matches_the_cpu() {
    let ctx = context();
    let kernels = ImageKernels::new(&ctx);
    let (w, h) = (97, 55);
    let image = rgb_image(w, h, 9);
    let mut r = noise(13);
    // Sparse known pixels (3%), as the splatted cloud gives, some with fractional weights.
    let weights = Raster {
        width: w,
        height: h,
        data: (0..w * h).map(|_| if r() < 0.03 { if r() < 0.8 { 1.0 } else { r() } } else { 0.0 }).collect(),
    };
    let cpu = pushpull::fill(&image, &weights, [0.5; 3]);
    let values = GpuImage::upload(&ctx, image.data.as_flattened(), w, h, 3).unwrap();
    let weights_gpu = GpuImage::upload(&ctx, &weights.data, w, h, 1).unwrap();
    let gpu = kernels.push_pull(&ctx, &values, &weights_gpu, [0.5; 3]).unwrap().download(&ctx).unwrap();
    let diff = max_difference(&gpu, cpu.data.as_flattened());
    assert!(diff <= 1e-5, "push-pull RGB: max difference {diff}");
    // Scalar (depth) with nothing known: the fallback everywhere.
    let depth = GpuImage::upload(&ctx, &vec![3.0; w * h], w, h, 1).unwrap();
    let none = GpuImage::upload(&ctx, &vec![0.0; w * h], w, h, 1).unwrap();
    let filled = kernels.push_pull(&ctx, &depth, &none, [7.0, 0.0, 0.0]).unwrap().download(&ctx).unwrap();
    assert!(filled.iter().all(|&v| v == 7.0));
    // Sizes that disagree are an error.
    let wrong = GpuImage::upload(&ctx, &[1.0; 4], 2, 2, 1).unwrap();
    assert!(kernels.push_pull(&ctx, &values, &wrong, [0.0; 3]).is_err());
}

use dynview_core::camera::{Camera, Intrinsics, Rigid3};
use dynview_core::render::warp::{compute_visibility, warp_view};
use dynview_gpu::WarpKernels;
use glam::DVec3;

fn camera(eye: DVec3, w: u32, h: u32) -> Camera {
    Camera {
        intrinsics: Intrinsics::from_vertical_fov(0.8, w, h),
        camera_from_world: Rigid3::camera_from_world_looking_at(eye, DVec3::new(0.0, 0.0, 0.0), DVec3::Y),
        width_px: w,
        height_px: h,
    }
}

#[test]
fn warps_and_visibility_on_the_gpu_match_the_cpu() {
    let ctx = context();
    let kernels = WarpKernels::new(&ctx);
    let (w, h) = (120, 70);
    let novel = camera(DVec3::new(0.3, 0.4, 5.0), w as u32, h as u32);
    let input_camera = camera(DVec3::new(-1.2, 0.2, 4.5), 160, 90);
    let input = rgb_image(160, 90, 21);
    // A depth map with occlusion edges: a near box in front of a slanted far plane, some
    // invalid pixels.
    let depth = Raster {
        width: w,
        height: h,
        data: (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if (40..70).contains(&x) && (20..45).contains(&y) {
                    3.0
                } else if x == 5 {
                    0.0
                } else {
                    5.0 + 0.01 * x as f32 + 0.02 * y as f32
                }
            })
            .collect(),
    };
    let mut cpu = warp_view(&novel, &depth, &input_camera, &input);
    compute_visibility(&mut cpu, 160 * 90, 0.01);
    // The same view twice: the packed second copy must equal the first.
    let mut cpu2 = warp_view(&novel, &depth, &novel, &rgb_image(w, h, 22));
    compute_visibility(&mut cpu2, w * h, 0.01);
    let depth_gpu = GpuImage::upload(&ctx, &depth.data, w, h, 1).unwrap();
    let input_gpu = GpuImage::upload(&ctx, input.data.as_flattened(), 160, 90, 3).unwrap();
    let second = GpuImage::upload(&ctx, rgb_image(w, h, 22).data.as_flattened(), w, h, 3).unwrap();
    let gpu =
        kernels.warp_views(&ctx, &novel, &depth_gpu, &[(input_camera, &input_gpu, None), (novel, &second, None)], 0.01, None).unwrap();
    let colors = gpu.colors.download(&ctx).unwrap();
    let visibilities = gpu.visibility.download(&ctx).unwrap();
    let valid = gpu.valid.download(&ctx).unwrap();
    let n = w * h;
    let (color, visibility) = (&colors[..3 * n], &visibilities[..n]);
    assert!((0..n).all(|i| (valid[i] > 0.0) == cpu.valid(i) && (valid[n + i] > 0.0) == cpu2.valid(i)), "validity differs");
    let diff2 = max_difference(&colors[3 * n..], cpu2.color.as_flattened());
    assert!(diff2 <= 1e-3, "second view color: max difference {diff2}");
    assert_eq!(&visibilities[n..], &cpu2.visibility[..]);
    // Colors: equal up to rounding where the sample position is the same.
    let diff = max_difference(color, cpu.color.as_flattened());
    assert!(diff <= 1e-3, "warped color: max difference {diff}");
    // Visibility is a discrete test; a last-bit difference in a depth may flip a pixel at a
    // tie. Allow at most 0.2% of pixels.
    let flips = visibility.iter().zip(&cpu.visibility).filter(|(a, b)| a != b).count();
    assert!(flips * 500 <= w * h, "visibility differs on {flips} of {} pixels", w * h);
    let visible = cpu.visibility.iter().filter(|&&v| v > 0.0).count();
    assert!(visible > w * h / 2 && visible < w * h, "the test scene must have visible and hidden pixels ({visible})");
    let outside = (0..w * h).filter(|&i| !cpu.valid(i)).count();
    assert!(outside > 0, "the test scene must have pixels outside the input");
}

use dynview_core::render::RenderParams;
use dynview_core::render::solve::{ColorTerms, ColorView};
use dynview_core::render::sparse::SplatMaps;
use dynview_core::render::weights;
use dynview_gpu::{AssembleKernels, GpuWarps, ViewChunks, ViewStack};

/// Largest difference relative to the magnitude (at least `floor`).
fn max_relative_difference(gpu: &[f32], cpu: &[f32], floor: f32) -> f32 {
    assert_eq!(gpu.len(), cpu.len());
    gpu.iter().zip(cpu).map(|(a, b)| (a - b).abs() / b.abs().max(floor)).fold(0.0, f32::max)
}

use dynview_core::render::plane::{PixelPlane, plane_weights};

#[test]
fn weights_and_system_assembly_on_the_gpu_match_the_cpu() {
    let ctx = context();
    let assemble = AssembleKernels::new(&ctx);
    // A support threshold that the test's point spacing crosses, so the plane's weights take
    // every value from 0 to lambda_plane.
    let params = RenderParams { plane_support: 0.05, ..RenderParams::default() };
    let (w, h) = (90, 50);
    let n = w * h;
    let novel = camera(DVec3::new(0.2, 0.3, 5.0), w as u32, h as u32);
    let inputs = [
        (camera(DVec3::new(-1.0, 0.2, 4.6), 120, 70), rgb_image(120, 70, 31)),
        (camera(DVec3::new(1.3, 0.1, 4.4), 120, 70), rgb_image(120, 70, 37)),
    ];
    let depth = Raster {
        width: w,
        height: h,
        data: (0..n)
            .map(|i| if (30..60).contains(&(i % w)) && (10..30).contains(&(i / w)) { 3.5 } else { 5.0 + 0.01 * (i % w) as f32 })
            .collect(),
    };
    let warps: Vec<_> = inputs
        .iter()
        .map(|(cam, img)| {
            let mut warp = warp_view(&novel, &depth, cam, img);
            compute_visibility(&mut warp, img.data.len(), params.visibility_tolerance);
            warp
        })
        .collect();
    // The current color: the first warp where valid, noise elsewhere, so weights vary.
    let mut r = noise(41);
    let color = Raster {
        width: w,
        height: h,
        data: (0..n).map(|i| if warps[0].valid(i) && r() < 0.8 { warps[0].color[i] } else { [r(), r(), r()] }).collect(),
    };
    let mut sparse =
        SplatMaps { depth: Raster::filled(w, h, f32::INFINITY), color: Raster::filled(w, h, [0.0; 3]), mask: Raster::filled(w, h, 0.0) };
    // Points on the left two thirds only: the plane pulls on the right, partly in between.
    for i in (0..n).step_by(17).filter(|i| i % w < 2 * w / 3) {
        sparse.depth.data[i] = 4.0 + r();
        sparse.color.data[i] = if r() < 0.7 { color.data[i] } else { [r(), r(), r()] };
        sparse.mask.data[i] = 1.0;
    }
    let temporal: Vec<f32> = (0..n).map(|_| if r() < 0.7 { 0.1 * r() } else { 0.0 }).collect();
    let previous_depth: Vec<f32> = (0..n).map(|_| 4.0 + r()).collect();
    let previous_color: Vec<Rgb> = (0..n).map(|_| [r(), r(), r()]).collect();
    // A plane whose clamp is reached at both ends; its weights as at pyramid level 1.
    let plane = PixelPlane { coefficients: [0.002, -0.003, 0.2], inverse_depth_range: [0.15, 0.3] };
    let plane_weight = plane_weights(&sparse.mask, 1, params.lambda_plane, params.plane_support);
    let plane_depth: Vec<f32> = (0..n).map(|i| plane.depth_at(i % w, i / w)).collect();

    // CPU, as the frame loop does it.
    let w_p: Vec<Vec<f32>> = warps.iter().map(|wp| weights::projection_weights(wp, &color, params.sigma)).collect();
    let mut sum_wp = vec![0.0f32; n];
    let mut sum_vis = vec![0.0f32; n];
    for (warp, wp) in warps.iter().zip(&w_p) {
        for i in 0..n {
            sum_wp[i] += wp[i];
            sum_vis[i] += warp.visibility[i];
        }
    }
    let depth_terms = DepthTerms {
        width: w,
        height: h,
        w_d: weights::depth_smoothness_weights(&color, &sum_wp, &sum_vis, &params),
        attach: weights::sparse_weights(&sparse, &color, params.sigma).iter().map(|&x| params.lambda_pc * x).collect(),
        sparse_depth: sparse.depth.data.clone(),
        temporal: temporal.clone(),
        previous_depth: previous_depth.clone(),
        plane_weight: plane_weight.clone(),
        plane_depth,
    };
    let cpu_depth = depth_terms.system();
    let color_terms = ColorTerms {
        width: w,
        height: h,
        views: warps.iter().zip(&w_p).map(|(warp, w_p)| ColorView { warp, w_p }).collect(),
        lambda_p: params.lambda_p,
        lambda_g: params.lambda_g,
        temporal: temporal.clone(),
        previous_color: previous_color.clone(),
    };
    let cpu_color = color_terms.system();

    // GPU: all views in one buffer, and each view in its own (as where one binding cannot
    // hold them all); the split sums per chunk and must give the same systems.
    let up = |data: &[f32], rows: usize, channels: usize| GpuImage::upload(&ctx, data, w, rows, channels).unwrap();
    let packed = |f: &dyn Fn(&dynview_core::render::warp::ViewWarp) -> Vec<f32>| warps.iter().flat_map(f).collect::<Vec<f32>>();
    let color_gpu = up(color.data.as_flattened(), h, 3);
    let sparse_color_mask: Vec<f32> = (0..n)
        .flat_map(|i| {
            let c = sparse.color.data[i];
            [c[0], c[1], c[2], sparse.mask.data[i]]
        })
        .collect();
    let temporal_depth: Vec<f32> = (0..n).flat_map(|i| [temporal[i], previous_depth[i]]).collect();
    let temporal_color: Vec<f32> = (0..n)
        .flat_map(|i| {
            let c = previous_color[i];
            [temporal[i], c[0], c[1], c[2]]
        })
        .collect();
    let rows = assemble.support_rows(&ctx, &up(&sparse.mask.data, h, 1), 1).unwrap();
    let prior = assemble.plane_prior(&ctx, &params, &rows, &up(&temporal_depth, h, 2), &plane, 1).unwrap();
    // Window sums of a 0/1 mask are integers, so the plane's weights differ from the CPU's by
    // no more than the rounding of the fade's multiply and add, which a GPU may fuse (lavapipe
    // gives the CPU's bits; an NVIDIA H200 differs in the last bit of 88 weights of 4500).
    let prior_weights: Vec<f32> = prior.download(&ctx).unwrap().chunks(2).map(|c| c[0]).collect();
    let cpu_weights: Vec<f32> = (0..n).map(|i| temporal[i] + plane_weight[i]).collect();
    let diff = max_difference(&prior_weights, &cpu_weights);
    assert!(diff <= 1e-6, "temporal and plane weights: max difference {diff}");
    let cpu_w_p: Vec<f32> =
        warps.iter().zip(&w_p).flat_map(|(warp, wp)| (0..n).map(|i| if warp.valid(i) { wp[i] } else { -1.0 })).collect();
    let cpu_view_weight: Vec<f32> = (0..n).map(|i| w_p.iter().map(|wp| wp[i]).sum()).collect();
    for split in [ViewChunks::single(2), ViewChunks { count: 2, per_chunk: 1 }] {
        let stack = |data: Vec<f32>, channels: usize| ViewStack::upload(&ctx, split, w, h, channels, &data).unwrap();
        let gpu_warps = GpuWarps {
            colors: stack(packed(&|wp| wp.color.as_flattened().to_vec()), 3),
            visibility: stack(packed(&|wp| wp.visibility.clone()), 1),
            valid: stack(packed(&|wp| (0..n).map(|i| if wp.valid(i) { 1.0 } else { 0.0 }).collect()), 1),
        };
        let w_p_gpu = assemble.projection_weights(&ctx, &params, &color_gpu, &gpu_warps).unwrap();
        let gpu_depth = assemble
            .depth_system(
                &ctx,
                &params,
                &color_gpu,
                &w_p_gpu,
                &gpu_warps.visibility,
                &up(&sparse_color_mask, h, 4),
                &up(&sparse.depth.data, h, 1),
                &prior,
            )
            .unwrap();
        let gpu_color = assemble.color_system(&ctx, &params, &gpu_warps.colors, &w_p_gpu, &up(&temporal_color, h, 4)).unwrap();
        let d = max_difference(&w_p_gpu.download(&ctx).unwrap(), &cpu_w_p);
        assert!(d <= 1e-5, "{split:?}: w_P: max difference {d}");
        let d = max_relative_difference(
            &assemble.view_weight(&ctx, &params, &w_p_gpu).unwrap().download(&ctx).unwrap(),
            &cpu_view_weight,
            1e-3,
        );
        assert!(d <= 1e-5, "{split:?}: view weight: max relative difference {d}");
        for (name, gpu, cpu) in [
            ("depth right", &gpu_depth.right, &cpu_depth.right),
            ("depth down", &gpu_depth.down, &cpu_depth.down),
            ("depth inv_diag", &gpu_depth.inv_diag, &cpu_depth.inv_diag),
            ("depth rhs", &gpu_depth.rhs, &cpu_depth.rhs),
            ("color right", &gpu_color.right, &cpu_color.right),
            ("color down", &gpu_color.down, &cpu_color.down),
            ("color inv_diag", &gpu_color.inv_diag, &cpu_color.inv_diag),
        ] {
            let d = max_relative_difference(&gpu.download(&ctx).unwrap(), cpu, 1e-3);
            assert!(d <= 1e-3, "{split:?}: {name}: max relative difference {d}");
        }
        let d = max_relative_difference(&gpu_color.rhs.download(&ctx).unwrap(), cpu_color.rhs.as_flattened(), 1e-2);
        assert!(d <= 1e-3, "{split:?}: color rhs: max relative difference {d}");
    }
    // The scene exercises the terms: clamped and free w_D, sparse attachment, invalid warps.
    assert!(depth_terms.attach.iter().any(|&a| a > 0.5) && cpu_w_p.iter().any(|&v| v < 0.0));
    // ... and the plane: full pull far from the points, none among them, partial in between.
    let full = params.lambda_plane;
    assert!(plane_weight.contains(&full) && plane_weight.contains(&0.0) && plane_weight.iter().any(|&p| p > 0.0 && p < full));
}

use dynview_core::render::sparse::{project_cloud, warp_frame};
use dynview_core::scene::PointCloud;
use dynview_gpu::{GpuCloud, SplatKernels};

/// Compares GPU splat maps with the CPU's: pixels whose mask differs (a rounding flip at a
/// half-pixel boundary) must be rare; where both have a sample, depth and color must agree.
fn assert_splats_agree(ctx: &GpuContext, gpu: &dynview_gpu::GpuSplat, cpu: &SplatMaps, what: &str) {
    let mask = gpu.mask.download(ctx).unwrap();
    let depth = gpu.depth.download(ctx).unwrap();
    let color = gpu.color.download(ctx).unwrap();
    let n = mask.len();
    let flips = mask.iter().zip(&cpu.mask.data).filter(|(a, b)| a != b).count();
    let covered = cpu.mask.data.iter().filter(|&&m| m > 0.0).count();
    assert!(covered > n / 20, "{what}: the test must cover pixels ({covered})");
    assert!(flips * 1000 <= covered, "{what}: coverage differs on {flips} of {covered} pixels");
    let mut worst = (0.0f32, 0.0f32);
    for i in 0..n {
        if mask[i] > 0.0 && cpu.mask.data[i] > 0.0 {
            worst.0 = worst.0.max((depth[i] - cpu.depth.data[i]).abs() / cpu.depth.data[i]);
            for k in 0..3 {
                worst.1 = worst.1.max((color[i * 3 + k] - cpu.color.data[i][k]).abs());
            }
        } else if mask[i] == 0.0 && cpu.mask.data[i] == 0.0 {
            assert!(depth[i].is_infinite(), "{what}: empty pixel {i} must have infinite depth");
        }
    }
    assert!(worst.0 <= 1e-5 && worst.1 <= 1e-6, "{what}: depth {} (relative) color {} max differences", worst.0, worst.1);
}

#[test]
fn cloud_and_frame_splats_on_the_gpu_match_the_cpu() {
    let ctx = context();
    let kernels = SplatKernels::new(&ctx);
    let mut r = noise(51);
    // Points in front of and behind the camera, some off the image, and exact duplicates of
    // other colors (the first one must win, as on the CPU).
    let mut cloud = PointCloud::default();
    for _ in 0..4000 {
        cloud.positions_world.push([6.0 * r() - 3.0, 4.0 * r() - 2.0, 8.0 * r() - 4.0]);
        cloud.colors.push([(255.0 * r()) as u8, (255.0 * r()) as u8, (255.0 * r()) as u8]);
    }
    for i in 0..200 {
        let p = cloud.positions_world[i];
        cloud.positions_world.push(p);
        cloud.colors.push([1, 2, 3]);
    }
    let cam = camera(DVec3::new(0.5, 0.5, 6.0), 80, 48);
    let cpu = project_cloud(&cloud, &cam);
    let gpu = kernels.project_cloud(&ctx, &GpuCloud::upload(&ctx, &cloud).unwrap(), &cam).unwrap();
    assert_splats_agree(&ctx, &gpu, &cpu, "cloud");
    // Footprints of the CPU's maps (uploaded, so both start from the same maps): the same
    // pixels take the same point, and the counters give the covered pixels after.
    let upload_maps = |maps: &SplatMaps| dynview_gpu::GpuSplat {
        depth: GpuImage::upload(&ctx, &maps.depth.data, 80, 48, 1).unwrap(),
        color: GpuImage::upload(&ctx, maps.color.data.as_flattened(), 80, 48, 3).unwrap(),
        mask: GpuImage::upload(&ctx, &maps.mask.data, 80, 48, 1).unwrap(),
    };
    for radius in [0, 2] {
        let cpu_wide = cpu.with_footprint(radius);
        let (gpu_wide, counters) = kernels.with_footprint(&ctx, &upload_maps(&cpu), radius).unwrap();
        assert_eq!(gpu_wide.mask.download(&ctx).unwrap(), cpu_wide.mask.data, "footprint {radius}: mask");
        assert_eq!(gpu_wide.depth.download(&ctx).unwrap(), cpu_wide.depth.data, "footprint {radius}: depth");
        assert_eq!(gpu_wide.color.download(&ctx).unwrap(), cpu_wide.color.data.as_flattened(), "footprint {radius}: color");
        assert_eq!(counters.download(&ctx).unwrap()[1].to_bits() as usize, cpu_wide.covered(), "footprint {radius}: count");
    }
    assert!(cpu.with_footprint(2).covered() > 2 * cpu.covered(), "the footprints must widen the maps");
    // An empty cloud gives empty maps.
    let empty = kernels.project_cloud(&ctx, &GpuCloud::upload(&ctx, &PointCloud::default()).unwrap(), &cam).unwrap();
    assert!(empty.mask.download(&ctx).unwrap().iter().all(|&m| m == 0.0));

    // A rendered frame forward-warped into a moved camera.
    let (w, h) = (64, 40);
    let source = camera(DVec3::new(0.3, 0.2, 5.0), w as u32, h as u32);
    let target = camera(DVec3::new(0.6, 0.1, 4.8), 70, 44);
    let depth = Raster {
        width: w,
        height: h,
        data: (0..w * h).map(|i| if (20..40).contains(&(i % w)) { 3.5 } else { 5.0 + 0.02 * (i / w) as f32 }).collect(),
    };
    let color = rgb_image(w, h, 57);
    let cpu = warp_frame(&source, &depth, &color, &target);
    let gpu = kernels
        .warp_frame(
            &ctx,
            &source,
            &GpuImage::upload(&ctx, &depth.data, w, h, 1).unwrap(),
            &GpuImage::upload(&ctx, color.data.as_flattened(), w, h, 3).unwrap(),
            &target,
        )
        .unwrap();
    assert_splats_agree(&ctx, &gpu, &cpu, "frame");
}
