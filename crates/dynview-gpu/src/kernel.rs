//! A compute pipeline with its bind group layout: a uniform block at binding 0 (at a dynamic
//! offset into the context's shared uniform buffer), then storage buffers.

use crate::context::GpuContext;
use crate::recorder::{DispatchTarget, next_kernel_id};

/// Workgroup size of the linear kernels (`@workgroup_size(64)`, dispatched over `n x 1`):
/// their index comes from `common/linear.wgsl`.
pub(crate) const LINEAR_WORKGROUP: u32 = 64;

/// A compute pipeline whose bind group is a uniform block then storage buffers.
#[derive(Debug)]
pub(crate) struct Kernel {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    workgroup: u32,
    id: u64,
}

impl Kernel {
    /// `storage[i]` is true for a read-only binding `i + 1`.
    pub(crate) fn new(ctx: &GpuContext, module: &wgpu::ShaderModule, entry: &str, storage_read_only: &[bool], workgroup: u32) -> Self {
        let device = &ctx.device;
        let buffer_entry = |binding: u32, ty: wgpu::BufferBindingType| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: binding == 0, min_binding_size: None },
            count: None,
        };
        let mut entries = vec![buffer_entry(0, wgpu::BufferBindingType::Uniform)];
        for (i, &read_only) in storage_read_only.iter().enumerate() {
            entries.push(buffer_entry(i as u32 + 1, wgpu::BufferBindingType::Storage { read_only }));
        }
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(entry), entries: &entries });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(entry),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&pipeline_layout),
            module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        });
        Self { pipeline, layout, workgroup, id: next_kernel_id() }
    }

    /// Records one dispatch covering `width x height` invocations (`ceil(n / workgroup)`
    /// groups per axis) with `uniform` and `buffers`.
    pub(crate) fn dispatch(&self, ctx: &GpuContext, uniform: &[u8], buffers: &[&wgpu::Buffer], width: usize, height: usize) {
        self.dispatch_sequence(ctx, &[uniform], &[0], buffers, width, height);
    }

    /// Records one dispatch per entry of `sequence`, each with uniform block
    /// `uniforms[sequence[i]]` (blocks of one layout), over the same buffers and size.
    pub(crate) fn dispatch_sequence(
        &self,
        ctx: &GpuContext,
        uniforms: &[&[u8]],
        sequence: &[usize],
        buffers: &[&wgpu::Buffer],
        width: usize,
        height: usize,
    ) {
        let groups = if self.workgroup == LINEAR_WORKGROUP {
            // A linear kernel over `width` elements, folded into rows (`common/linear.wgsl`).
            debug_assert_eq!(height, 1, "a linear kernel covers width x 1");
            let total = (width as u32).div_ceil(LINEAR_WORKGROUP).max(1);
            let row = ctx.device.limits().max_compute_workgroups_per_dimension.max(1);
            if total <= row { (total, 1, 1) } else { (row, total.div_ceil(row), 1) }
        } else {
            ((width as u32).div_ceil(self.workgroup), (height as u32).div_ceil(self.workgroup), 1)
        };
        let target = DispatchTarget { id: self.id, pipeline: &self.pipeline, layout: &self.layout };
        ctx.dispatch(&target, uniforms, sequence, buffers, groups);
    }
}
