//! dynview's renderer on the GPU, as wgpu compute passes (WGSL in `src/shaders/`), natively
//! (Vulkan; lavapipe in tests) and in the browser (WebGPU).
//!
//! [`GpuRenderer`] runs the full method and its no-temporal ablation of METHOD.md Part 2 level
//! by level on the GPU: z-buffered splats of the cloud and of the previous frame
//! ([`SplatKernels`]), the sparse consistency filter, push-pull and pyramid resampling
//! ([`ImageKernels`]), backward warps with visibility ([`WarpKernels`]), the weights and the
//! assembly of both systems ([`AssembleKernels`]), the color initial guess and `w_T`
//! ([`LevelKernels`]), and red-black sweeps ([`GridSolver`]). Each matches its dynview-core
//! counterpart; a whole frame matches the CPU's (tests/gpu_parity.rs). The baselines stay on
//! the CPU.
//!
//! Images live in storage buffers taken from a pool on the context: each size is allocated
//! once and reused by every later frame at that resolution. [`FrameDisplay`] draws a frame into
//! a canvas (or any texture) straight from those buffers. [`GpuContext::start_profile`] times
//! every compute pass with timestamp queries, summed per level and stage ([`StageTime`]).

mod assemble;
mod context;
mod display;
mod image;
mod kernel;
mod level;
mod profile;
mod readback;
mod renderer;
mod solver;
mod splat;
mod warp;

pub use assemble::{AssembleKernels, GpuSystem, PackedViews};
pub use context::{GpuContext, GpuError};
pub use display::FrameDisplay;
pub use image::{GpuImage, ImageKernels};
pub use level::{LevelKernels, MAX_VIEWS};
pub use profile::StageTime;
pub use readback::{read_bytes, read_floats};
pub use renderer::{GpuFrame, GpuInputs, GpuRenderer};
pub use solver::GridSolver;
pub use splat::{GpuCloud, GpuSplat, SplatKernels};
pub use warp::{GpuWarps, WarpKernels};

/// wgpu, as this crate uses it (for targets to draw into).
pub use wgpu;

/// Every WGSL shader of the crate, by file name (validated by naga in the tests).
pub const SHADERS: &[(&str, &str)] = &[
    ("red_black.wgsl", include_str!("shaders/red_black.wgsl")),
    ("pyramid.wgsl", include_str!("shaders/pyramid.wgsl")),
    ("pushpull.wgsl", include_str!("shaders/pushpull.wgsl")),
    ("warp.wgsl", include_str!("shaders/warp.wgsl")),
    ("assemble.wgsl", include_str!("shaders/assemble.wgsl")),
    ("splat_project.wgsl", include_str!("shaders/splat_project.wgsl")),
    ("splat_resolve.wgsl", include_str!("shaders/splat_resolve.wgsl")),
    ("consistency.wgsl", include_str!("shaders/consistency.wgsl")),
    ("frame.wgsl", include_str!("shaders/frame.wgsl")),
    ("depth_range.wgsl", include_str!("shaders/depth_range.wgsl")),
    ("display.wgsl", include_str!("shaders/display.wgsl")),
];
