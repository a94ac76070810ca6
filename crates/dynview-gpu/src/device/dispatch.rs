//! Recording a kernel's dispatches on a context: the workgroups for the size, then the
//! context's recorder (into the open frame's compute pass, or submitted at once outside a frame).

use crate::device::{context::GpuContext, kernel::Kernel};

impl Kernel {
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
        let groups = self.workgroups(&ctx.device, width, height);
        ctx.dispatch(&self.target(), uniforms, sequence, buffers, groups);
    }
}
