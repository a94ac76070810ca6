//! A compute pipeline with its bind group layout: a uniform block at binding 0 (at a dynamic
//! offset into the context's shared uniform buffer), then storage buffers; and the workgroups
//! a dispatch over a size takes. Recording its dispatches on a context is in `dispatch.rs`.

use crate::device::recorder::{DispatchTarget, next_kernel_id};

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
    pub(crate) fn new(device: &wgpu::Device, module: &wgpu::ShaderModule, entry: &str, storage_read_only: &[bool], workgroup: u32) -> Self {
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

    /// The workgroups covering `width x height` invocations on `device`: `ceil(n / workgroup)`
    /// per axis, a linear kernel's folded into rows of at most the device's groups per dimension.
    pub(crate) fn workgroups(&self, device: &wgpu::Device, width: usize, height: usize) -> (u32, u32, u32) {
        if self.workgroup == LINEAR_WORKGROUP {
            // A linear kernel over `width` elements, folded into rows (`common/linear.wgsl`).
            debug_assert_eq!(height, 1, "a linear kernel covers width x 1");
            let total = (width as u32).div_ceil(LINEAR_WORKGROUP).max(1);
            let row = device.limits().max_compute_workgroups_per_dimension.max(1);
            if total <= row { (total, 1, 1) } else { (row, total.div_ceil(row), 1) }
        } else {
            ((width as u32).div_ceil(self.workgroup), (height as u32).div_ceil(self.workgroup), 1)
        }
    }

    /// What the recorder needs of the kernel for a dispatch.
    pub(crate) fn target(&self) -> DispatchTarget<'_> {
        DispatchTarget { id: self.id, pipeline: &self.pipeline, layout: &self.layout }
    }
}
