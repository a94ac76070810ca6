//! dynview's renderer on the GPU, as wgpu compute passes (WGSL in `src/shaders/`), natively
//! (Vulkan; lavapipe in tests) and in the browser (WebGPU).
//!
//! Status: the device context and the red-black solver of the depth and color systems
//! ([`GridSolver`]), which match dynview-core's [`dynview_core::render::solve::GridSystem`]
//! sweep for sweep. The other stages of METHOD.md Part 2 (projection, warps, visibility,
//! weights, pyramid, push-pull, temporal warp) still run on the CPU.

mod context;
mod solver;

pub use context::{GpuContext, GpuError};
pub use solver::GridSolver;

/// Every WGSL shader of the crate, by file name (validated by naga in the tests).
pub const SHADERS: &[(&str, &str)] = &[("red_black.wgsl", include_str!("shaders/red_black.wgsl"))];
