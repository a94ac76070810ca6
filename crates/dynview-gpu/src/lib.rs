//! dynview's renderer on the GPU, as wgpu compute passes (WGSL in `src/shaders/`), natively
//! (Vulkan; lavapipe in tests) and in the browser (WebGPU).
//!
//! Status: the device context, the red-black solver of the depth and color systems
//! ([`GridSolver`], matching dynview-core's [`dynview_core::render::solve::GridSystem`] sweep
//! for sweep), and the image kernels ([`ImageKernels`]: pyramid down/upsampling and push-pull
//! fill, matching dynview-core's `pyramid` and `pushpull`). The other stages of METHOD.md
//! Part 2 (projection, warps, visibility, weights, temporal warp) and the frame loop are still
//! to come; the renderer runs on the CPU.

mod context;
mod image;
mod solver;

pub use context::{GpuContext, GpuError};
pub use image::{GpuImage, ImageKernels};
pub use solver::GridSolver;

/// Every WGSL shader of the crate, by file name (validated by naga in the tests).
pub const SHADERS: &[(&str, &str)] = &[
    ("red_black.wgsl", include_str!("shaders/red_black.wgsl")),
    ("pyramid.wgsl", include_str!("shaders/pyramid.wgsl")),
    ("pushpull.wgsl", include_str!("shaders/pushpull.wgsl")),
];
