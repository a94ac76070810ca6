//! dynview's renderer on the GPU, as wgpu compute passes (WGSL in `src/shaders/`), natively
//! (Vulkan; lavapipe in tests) and in the browser (WebGPU).
//!
//! Status: the device context and, each matching its dynview-core counterpart, the red-black
//! solver of the depth and color systems ([`GridSolver`]), the image kernels
//! ([`ImageKernels`]: pyramid down/upsampling, push-pull fill), the backward warps with their
//! visibility ([`WarpKernels`]), and the weights with the assembly of both systems
//! ([`AssembleKernels`]), and z-buffered splats of the cloud and of the previous frame
//! ([`SplatKernels`]). Still to come: the sparse consistency filter, `w_T`, the color initial
//! guess and the frame loop; until then the renderer runs on the CPU.

mod assemble;
mod context;
mod image;
mod kernel;
mod solver;
mod splat;
mod warp;

pub use assemble::{AssembleKernels, GpuSystem, PackedViews};
pub use context::{GpuContext, GpuError};
pub use image::{GpuImage, ImageKernels};
pub use solver::GridSolver;
pub use splat::{GpuCloud, GpuSplat, SplatKernels};
pub use warp::{GpuWarp, WarpKernels};

/// Every WGSL shader of the crate, by file name (validated by naga in the tests).
pub const SHADERS: &[(&str, &str)] = &[
    ("red_black.wgsl", include_str!("shaders/red_black.wgsl")),
    ("pyramid.wgsl", include_str!("shaders/pyramid.wgsl")),
    ("pushpull.wgsl", include_str!("shaders/pushpull.wgsl")),
    ("warp.wgsl", include_str!("shaders/warp.wgsl")),
    ("assemble.wgsl", include_str!("shaders/assemble.wgsl")),
    ("splat_project.wgsl", include_str!("shaders/splat_project.wgsl")),
    ("splat_resolve.wgsl", include_str!("shaders/splat_resolve.wgsl")),
];
