//! The device layer: what every compute pass stands on, and nothing of the passes themselves.
//!
//! From the bottom up: the errors ([`error`]), the composed WGSL and compiling it on a device
//! ([`shaders`]), the future a wgpu callback fires ([`signal`]), the timestamp queries of a
//! profiled frame ([`timestamps`]), the recorder of commands, uniforms and bind groups
//! ([`recorder`]), compiled kernels ([`kernel`]), the buffer pool ([`pool`]), the context
//! ([`context`]), then what builds on the context: recording a kernel's dispatches
//! ([`dispatch`]), reading buffers back ([`readback`]), profiling ([`profile`]) and images in
//! pooled storage buffers ([`image`]); in tests, `shader_layout` checks a Rust mirror of a WGSL
//! struct. Arrows point down this list, never up, and never out of this folder to the passes or
//! the renderer.

pub(crate) mod context;
pub(crate) mod dispatch;
pub(crate) mod error;
pub(crate) mod image;
pub(crate) mod kernel;
pub(crate) mod pool;
pub(crate) mod profile;
pub(crate) mod readback;
pub(crate) mod recorder;
#[cfg(test)]
pub(crate) mod shader_layout;
pub(crate) mod shaders;
pub(crate) mod signal;
pub(crate) mod timestamps;
