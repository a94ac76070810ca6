//! dynview's renderer on the GPU, as wgpu compute passes (WGSL in `src/shaders/`), natively
//! (Vulkan; lavapipe in tests) and in the browser (WebGPU).
//!
//! [`GpuRenderer`] runs the full method and its no-temporal ablation of METHOD.md Part 2 level
//! by level on the GPU: z-buffered splats of the cloud and of the previous frame
//! ([`SplatKernels`]), the sparse consistency filter ([`ConsistencyKernels`]), the plates' static
//! mask ([`StaticMaskKernels`]), push-pull and
//! pyramid resampling ([`ImageKernels`]), backward warps with visibility ([`WarpKernels`]), the
//! weights and the assembly of both systems ([`AssembleKernels`]), the color initial guess
//! ([`BlendKernel`]), the color energy's rank preference where points are scarce
//! ([`RankKernels`]), `w_T` and the temporal terms ([`TemporalKernels`]), and red-black sweeps
//! ([`GridSolver`], in one of two kernels that give the same result, [`SweepKernel`]). Each matches its dynview-core counterpart; a whole frame matches the CPU's
//! (tests/gpu_parity.rs). The baselines stay on the CPU. The WGSL ([`SHADERS`]) is composed from
//! per-kernel files and shared code in `src/shaders/common/`; it owns the uniform layouts, which
//! the Rust mirrors are tested against.
//!
//! Images live in storage buffers taken from a pool on the context: each size is allocated
//! once and reused by every later frame at that resolution. A frame is recorded into one
//! command encoder and submitted once ([`GpuContext::frame`]); its dispatches share compute
//! passes, their uniform blocks share one buffer at dynamic offsets, and their bind groups are
//! cached, so a streaming frame creates none ([`GpuContext::counters`]). [`FrameDisplay`] draws a frame into
//! a canvas (or any texture) straight from those buffers. [`GpuContext::start_profile`] times
//! every compute pass with timestamp queries, summed per level and stage ([`StageTime`]).
//!
//! The source is in three layers, each importing only from those below it: `device/` (the
//! context, recording, kernels, read-back, profiling, images and the composed WGSL), `passes/`
//! (the compute passes, which use the device layer and each other without circles) and
//! `render/` (the frame loop, streaming and the display, on top of both).

mod device;
#[cfg(test)]
mod layout_tests;
mod passes;
mod render;

pub use device::context::{FrameGuard, GpuContext};
pub use device::error::GpuError;
pub use device::image::GpuImage;
pub use device::readback::{read_bytes, read_floats};
pub use device::recorder::GpuCounters;
pub use device::shaders::SHADERS;
pub use device::timestamps::StageTime;
pub use passes::assemble::{AssembleKernels, GpuSystem};
pub use passes::blend::{BlendKernel, MAX_VIEWS};
pub use passes::consistency::ConsistencyKernels;
pub use passes::pyramid::ImageKernels;
pub use passes::rank::RankKernels;
pub use passes::solver::{GridSolver, SweepKernel};
pub use passes::splat::{GpuCloud, GpuSplat, SplatKernels};
pub use passes::static_mask::StaticMaskKernels;
pub use passes::temporal::TemporalKernels;
pub use passes::views::{ViewChunks, ViewStack};
pub use passes::warp::{GpuWarps, WarpKernels};
pub use render::display::FrameDisplay;
pub use render::renderer::{GpuFrame, GpuInputs, GpuRenderer};
pub use render::streaming::{GpuStreamingRenderer, StreamRequest};

/// wgpu, as this crate uses it (for targets to draw into).
pub use wgpu;
