//! The red-black over-relaxed Gauss-Seidel solver of dynview-core's grid systems on the GPU
//! (`shaders/red_black.wgsl`): one dispatch per colour, all sweeps in one compute pass.

#[cfg(not(target_family = "wasm"))]
use dynview_core::raster::Rgb;
#[cfg(not(target_family = "wasm"))]
use dynview_core::render::solve::GridSystem;
#[cfg(not(target_family = "wasm"))]
use wgpu::util::DeviceExt;

use crate::context::{GpuContext, GpuError};
use crate::image::GpuImage;
use crate::kernel::Kernel;
use crate::shaders;

/// `red_black.wgsl`'s uniform block.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct SweepParams {
    width: u32,
    height: u32,
    parity: u32,
    channels: u32,
    omega: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

/// Side of the square workgroup of `red_black.wgsl`.
const WORKGROUP: u32 = 8;

/// The compiled sweep pipeline.
#[derive(Debug)]
pub struct GridSolver {
    sweep: Kernel,
}

impl GridSolver {
    /// Compiles the pipeline on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Self {
        let module = shaders::module(ctx, shaders::RED_BLACK);
        Self { sweep: Kernel::new(ctx, &module, "sweep", &[true, true, true, true, false], WORKGROUP) }
    }

    /// `sweeps` red-black sweeps of a system already on the GPU, on `u` (in place; `u`'s
    /// channels share the system).
    pub fn solve_on_gpu(&self, ctx: &GpuContext, sys: &crate::GpuSystem, u: &GpuImage, sweeps: usize, omega: f32) -> Result<(), GpuError> {
        let (w, h) = (u.width, u.height);
        for (name, image, channels) in
            [("right", &sys.right, 1), ("down", &sys.down, 1), ("inv_diag", &sys.inv_diag, 1), ("rhs", &sys.rhs, u.channels)]
        {
            if (image.width, image.height, image.channels) != (w, h, channels) {
                return Err(GpuError::Size(format!(
                    "system {name} is {}x{}x{}, unknowns {w}x{h}x{}",
                    image.width, image.height, image.channels, u.channels
                )));
            }
        }
        let buffers = [&sys.right.buffer, &sys.down.buffer, &sys.inv_diag.buffer, &sys.rhs.buffer, &u.buffer];
        self.record(ctx, buffers, w, h, u.channels as u32, sweeps, omega);
        Ok(())
    }

    /// Records `sweeps` sweeps over the buffers (right, down, inv_diag, rhs, u): one dispatch
    /// per colour, all in one compute pass.
    #[allow(clippy::too_many_arguments)]
    fn record(&self, ctx: &GpuContext, buffers: [&wgpu::Buffer; 5], width: usize, height: usize, channels: u32, sweeps: usize, omega: f32) {
        let params =
            |parity| SweepParams { width: width as u32, height: height as u32, parity, channels, omega, _pad0: 0, _pad1: 0, _pad2: 0 };
        let (red, black) = (params(0), params(1));
        let sequence: Vec<usize> = (0..2 * sweeps).map(|i| i % 2).collect();
        self.sweep.dispatch_sequence(ctx, &[bytemuck::bytes_of(&red), bytemuck::bytes_of(&black)], &sequence, &buffers, width, height);
    }

    /// `sweeps` red-black sweeps of the depth system `sys` on `u` (in place), as
    /// [`GridSystem::sweep`] does them. Native only: it reads the result back, blocking.
    #[cfg(not(target_family = "wasm"))]
    pub fn solve_depth(&self, ctx: &GpuContext, sys: &GridSystem<f32>, u: &mut [f32], sweeps: usize, omega: f32) -> Result<(), GpuError> {
        self.solve(ctx, sys, &sys.rhs, u, 1, sweeps, omega)
    }

    /// `sweeps` red-black sweeps of the color system `sys` on `u` (in place; the three
    /// channels share the system). Native only: it reads the result back, blocking.
    #[cfg(not(target_family = "wasm"))]
    pub fn solve_color(&self, ctx: &GpuContext, sys: &GridSystem<Rgb>, u: &mut [Rgb], sweeps: usize, omega: f32) -> Result<(), GpuError> {
        let rhs: &[f32] = bytemuck::cast_slice(&sys.rhs);
        self.solve(ctx, sys, rhs, bytemuck::cast_slice_mut(u), 3, sweeps, omega)
    }

    #[cfg(not(target_family = "wasm"))]
    #[allow(clippy::too_many_arguments)]
    fn solve<T>(
        &self,
        ctx: &GpuContext,
        sys: &GridSystem<T>,
        rhs: &[f32],
        u: &mut [f32],
        channels: u32,
        sweeps: usize,
        omega: f32,
    ) -> Result<(), GpuError> {
        let n = sys.width * sys.height;
        let sizes_agree = [sys.right.len(), sys.down.len(), sys.inv_diag.len()].iter().all(|&l| l == n)
            && rhs.len() == n * channels as usize
            && u.len() == n * channels as usize;
        if !sizes_agree {
            return Err(GpuError::Size(format!("grid system of {}x{}: array lengths disagree", sys.width, sys.height)));
        }
        let limit = ctx.device.limits().max_storage_buffer_binding_size as usize;
        if std::mem::size_of_val(u) > limit {
            return Err(GpuError::Size(format!(
                "{} bytes of unknowns exceed the device's storage binding limit of {limit}",
                std::mem::size_of_val(u)
            )));
        }
        let device = &ctx.device;
        let storage = |label: &str, data: &[f32], usage: wgpu::BufferUsages| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: bytemuck::cast_slice(data), usage })
        };
        let read = wgpu::BufferUsages::STORAGE;
        let right = storage("right", &sys.right, read);
        let down = storage("down", &sys.down, read);
        let inv_diag = storage("inv_diag", &sys.inv_diag, read);
        let rhs = storage("rhs", rhs, read);
        let unknowns = storage("u", u, read | wgpu::BufferUsages::COPY_SRC);
        self.record(ctx, [&right, &down, &inv_diag, &rhs, &unknowns], sys.width, sys.height, channels, sweeps, omega);
        read_buffer(ctx, &unknowns, u)
    }
}

/// Reads `buffer` (which must have `COPY_SRC`) into `out`; blocks until the GPU is done
/// (native only).
#[cfg(not(target_family = "wasm"))]
pub(crate) fn read_buffer(ctx: &GpuContext, buffer: &wgpu::Buffer, out: &mut [f32]) -> Result<(), GpuError> {
    let floats = pollster::block_on(crate::readback::read_floats(ctx, buffer, out.len()))?;
    out.copy_from_slice(&floats);
    Ok(())
}

/// The uniform block's mirror, checked against the WGSL (`shaders/layout_tests.rs`).
#[cfg(test)]
pub(crate) fn wgsl_mirrors() -> Vec<crate::shaders::layout_tests::Mirror> {
    use crate::shaders::layout_tests::mirror;
    vec![mirror!(shaders::RED_BLACK, "Params", SweepParams { width, height, parity, channels, omega, _pad0, _pad1, _pad2 })]
}
