//! A compute pipeline with its bind group layout: a uniform block at binding 0, then storage
//! buffers.

use wgpu::util::DeviceExt;

use crate::context::GpuContext;

/// A compute pipeline whose bind group is a uniform block then storage buffers.
#[derive(Debug)]
pub(crate) struct Kernel {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    workgroup: u32,
}

impl Kernel {
    /// `storage[i]` is true for a read-only binding `i + 1`.
    pub(crate) fn new(ctx: &GpuContext, module: &wgpu::ShaderModule, entry: &str, storage_read_only: &[bool], workgroup: u32) -> Self {
        let device = &ctx.device;
        let buffer_entry = |binding: u32, ty: wgpu::BufferBindingType| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
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
        Self { pipeline, layout, workgroup }
    }

    /// Records one dispatch covering `width x height` invocations (`ceil(n / workgroup)`
    /// groups per axis) with `uniform` and `buffers`.
    pub(crate) fn dispatch(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        uniform: &[u8],
        buffers: &[&wgpu::Buffer],
        width: usize,
        height: usize,
    ) {
        let device = &ctx.device;
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("dims"),
            contents: uniform,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let mut entries = vec![wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() }];
        for (i, b) in buffers.iter().enumerate() {
            entries.push(wgpu::BindGroupEntry { binding: i as u32 + 1, resource: b.as_entire_binding() });
        }
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &self.layout, entries: &entries });
        let mut pass = ctx.begin_compute_pass(encoder, None);
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups((width as u32).div_ceil(self.workgroup), (height as u32).div_ceil(self.workgroup), 1);
    }
}
