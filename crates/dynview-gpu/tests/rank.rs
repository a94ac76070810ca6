//! The color energy's rank preference (`RenderParams::view_rank_exponent`) on the GPU equals
//! dynview-core's: the support map exactly, the scaled `w_P` to float rounding, and the
//! invalid-warp flags left alone.

use dynview_core::raster::Raster;
use dynview_core::render::plane::plane_weights;
use dynview_core::render::weights::{apply_rank_preference, rank_preferences};
use dynview_gpu::{AssembleKernels, GpuContext, GpuImage, RankKernels, ViewChunks, ViewStack};

/// A deterministic pseudo-random sequence in [0, 1).
fn noise(seed: u32) -> impl FnMut() -> f32 {
    let mut state = seed.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1u32 << 24) as f32
    }
}

#[test]
fn rank_preference_on_the_gpu_matches_the_cpu() {
    let ctx = GpuContext::new_blocking().unwrap_or_else(|e| panic!("{e}"));
    let kernels = RankKernels::new(&ctx);
    let (w, h, views) = (70, 45, 3);
    let n = w * h;
    let mut r = noise(7);
    // Points dense on the left, sparse in the middle, none on the right: u takes 0, 1 and
    // everything between.
    let mask = Raster {
        width: w,
        height: h,
        data: (0..n)
            .map(|i| {
                let x = i % w;
                let p = if x < w / 3 {
                    0.3
                } else if x < 2 * w / 3 {
                    0.01
                } else {
                    0.0
                };
                if r() < p { 1.0 } else { 0.0 }
            })
            .collect(),
    };
    let (level, support) = (1, 0.01);
    let cpu_unsupported = plane_weights(&mask, level, 1.0, support);
    assert!(cpu_unsupported.contains(&0.0) && cpu_unsupported.contains(&1.0));
    assert!(cpu_unsupported.iter().any(|&u| u > 0.05 && u < 0.95), "the fade must be exercised");
    let gpu_mask = GpuImage::upload(&ctx, &mask.data, w, h, 1).unwrap();
    let rows = AssembleKernels::new(&ctx).support_rows(&ctx, &gpu_mask, level).unwrap();
    let gpu_unsupported = kernels.unsupported(&ctx, &rows, level, support).unwrap();
    // The same sums and fade; a GPU may fuse the fade's multiply and add, which moves the last
    // bit (an NVIDIA H200 does, in 66 of 3150; lavapipe gives the CPU's bits).
    let gpu_support = gpu_unsupported.download(&ctx).unwrap();
    let support_diff = gpu_support.iter().zip(&cpu_unsupported).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
    assert!(gpu_support.len() == cpu_unsupported.len() && support_diff <= 1e-6, "the support map: max difference {support_diff}");

    // w_P of three views, some invalid (-1 on the GPU, 0 on the CPU); the views rank 1, 0.3
    // and 1e-5 of the best.
    let mut cpu_w_p: Vec<Vec<f32>> = (0..views).map(|_| (0..n).map(|_| if r() < 0.1 { 0.0 } else { r() }).collect()).collect();
    let invalid: Vec<bool> = (0..views * n).map(|j| cpu_w_p[j / n][j % n] == 0.0 && j % 2 == 0).collect();
    let gpu_input: Vec<f32> = (0..views * n).map(|j| if invalid[j] { -1.0 } else { cpu_w_p[j / n][j % n] }).collect();
    let preferences = rank_preferences(&[1.0, 0.3, 1e-5], 1.0);
    apply_rank_preference(&mut cpu_w_p, &preferences, &cpu_unsupported);
    // Split two and one a buffer: each chunk takes its own views' preferences.
    let gpu_w_p = ViewStack::upload(&ctx, ViewChunks { count: views, per_chunk: 2 }, w, h, 1, &gpu_input).unwrap();
    kernels.apply(&ctx, &gpu_w_p, &gpu_unsupported, &preferences).unwrap();
    let out = gpu_w_p.download(&ctx).unwrap();
    let mut worst = 0.0f32;
    for j in 0..views * n {
        if invalid[j] {
            assert_eq!(out[j], -1.0, "an invalid warp's flag at {j}");
        } else {
            worst = worst.max((out[j] - cpu_w_p[j / n][j % n]).abs());
        }
    }
    assert!(worst < 1e-6, "largest difference {worst}");
    // The preference did something: where no point is, the worst view lost its weight.
    let unsupported_sum =
        |values: &[f32]| -> f32 { (0..n).filter(|&i| cpu_unsupported[i] == 1.0).map(|i| values[2 * n + i].max(0.0)).sum() };
    let before = unsupported_sum(&gpu_input);
    assert!(before > 10.0 && unsupported_sum(&out) < 1e-4 * before, "{before} -> {}", unsupported_sum(&out));
    // Too many views for the uniform block is an error, not a panic.
    assert!(kernels.apply(&ctx, &gpu_w_p, &gpu_unsupported, &[0.0; 9]).is_err());
}
