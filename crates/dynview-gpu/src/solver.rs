//! The red-black over-relaxed Gauss-Seidel solver of dynview-core's grid systems on the GPU
//! (`shaders/red_black.wgsl`): one dispatch per colour, all sweeps in one command buffer.

#[cfg(not(target_family = "wasm"))]
use dynview_core::raster::Rgb;
#[cfg(not(target_family = "wasm"))]
use dynview_core::render::solve::GridSystem;
use wgpu::util::DeviceExt;

use crate::context::{GpuContext, GpuError};
use crate::image::GpuImage;
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
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

impl GridSolver {
    /// Compiles the pipeline on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Self {
        let device = &ctx.device;
        let module = shaders::module(ctx, shaders::RED_BLACK);
        let uniform = wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("red_black"),
            entries: &[
                uniform,
                storage_entry(1, true),
                storage_entry(2, true),
                storage_entry(3, true),
                storage_entry(4, true),
                storage_entry(5, false),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("red_black"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("red_black"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("sweep"),
            compilation_options: Default::default(),
            cache: None,
        });
        Self { pipeline, layout }
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
        let mut encoder = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("red_black") });
        self.record(ctx, &mut encoder, buffers, w, h, u.channels as u32, sweeps, omega);
        ctx.queue.submit([encoder.finish()]);
        Ok(())
    }

    /// Records `sweeps` sweeps over the buffers (right, down, inv_diag, rhs, u).
    #[allow(clippy::too_many_arguments)]
    fn record(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        buffers: [&wgpu::Buffer; 5],
        width: usize,
        height: usize,
        channels: u32,
        sweeps: usize,
        omega: f32,
    ) {
        let device = &ctx.device;
        let bind_groups: Vec<wgpu::BindGroup> = (0..2u32)
            .map(|parity| {
                let params =
                    SweepParams { width: width as u32, height: height as u32, parity, channels, omega, _pad0: 0, _pad1: 0, _pad2: 0 };
                let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("red_black params"),
                    contents: bytemuck::bytes_of(&params),
                    usage: wgpu::BufferUsages::UNIFORM,
                });
                let mut entries = vec![wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() }];
                for (i, b) in buffers.iter().enumerate() {
                    entries.push(wgpu::BindGroupEntry { binding: i as u32 + 1, resource: b.as_entire_binding() });
                }
                device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("red_black"), layout: &self.layout, entries: &entries })
            })
            .collect();
        let mut pass = ctx.begin_compute_pass(encoder, Some("red_black"));
        pass.set_pipeline(&self.pipeline);
        let groups = ((width as u32).div_ceil(WORKGROUP), (height as u32).div_ceil(WORKGROUP));
        for _ in 0..sweeps {
            for bind_group in &bind_groups {
                pass.set_bind_group(0, bind_group, &[]);
                pass.dispatch_workgroups(groups.0, groups.1, 1);
            }
        }
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
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("red_black") });
        self.record(ctx, &mut encoder, [&right, &down, &inv_diag, &rhs, &unknowns], sys.width, sys.height, channels, sweeps, omega);
        ctx.queue.submit([encoder.finish()]);
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
