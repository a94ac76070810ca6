//! Recording GPU work with little host overhead: one command encoder for everything recorded
//! while a frame is open ([`crate::GpuContext::frame`]), submitted once when it closes;
//! dispatches share a compute pass until something else (a copy, a clear, a render pass)
//! needs the encoder; every uniform block goes into one shared buffer at a dynamic offset, so a
//! bind group depends only on its kernel and storage buffers and is built once and reused
//! while those buffers live (the image pool hands the same buffers to every frame of one
//! resolution).

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::device::timestamps::Profiler;

/// Work recorded since the context was made; the difference of two snapshots gives a frame's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GpuCounters {
    /// Queue submissions.
    pub submits: u64,
    /// Compute passes begun.
    pub passes: u64,
    /// Compute dispatches recorded.
    pub dispatches: u64,
    /// Bind groups created (the others came from the cache).
    pub bind_groups_created: u64,
    /// Bytes of uniform data written, alignment padding included.
    pub uniform_bytes: u64,
    /// Bytes of the storage buffers bound, summed over the dispatches (an upper bound of the
    /// memory traffic).
    pub bytes_bound: u64,
}

impl std::ops::Sub for GpuCounters {
    type Output = Self;

    fn sub(self, earlier: Self) -> Self {
        Self {
            submits: self.submits - earlier.submits,
            passes: self.passes - earlier.passes,
            dispatches: self.dispatches - earlier.dispatches,
            bind_groups_created: self.bind_groups_created - earlier.bind_groups_created,
            uniform_bytes: self.uniform_bytes - earlier.uniform_bytes,
            bytes_bound: self.bytes_bound - earlier.bytes_bound,
        }
    }
}

/// Bytes of the shared uniform buffer; a submit whose uniforms would overflow it is split.
pub(crate) const UNIFORM_ARENA_BYTES: u64 = 1 << 20;

/// Most bind groups cached; the cache is emptied when it would grow past this (it holds its
/// buffers alive).
const BIND_GROUP_CACHE: usize = 4096;

static NEXT_KERNEL: AtomicU64 = AtomicU64::new(1);

/// A process-unique id for a kernel (the bind-group cache's key).
pub(crate) fn next_kernel_id() -> u64 {
    NEXT_KERNEL.fetch_add(1, Ordering::Relaxed)
}

/// What a dispatch needs of its kernel.
pub(crate) struct DispatchTarget<'a> {
    pub(crate) id: u64,
    pub(crate) pipeline: &'a wgpu::ComputePipeline,
    pub(crate) layout: &'a wgpu::BindGroupLayout,
}

#[derive(PartialEq, Eq, Hash)]
struct BindKey {
    kernel: u64,
    uniform_size: u64,
    buffers: Vec<wgpu::Buffer>,
}

/// The open encoder and pass, the uniforms staged for the next submit, the bind-group cache,
/// the counters, and the profiler while one runs.
pub(crate) struct Recorder {
    device: wgpu::Device,
    queue: wgpu::Queue,
    arena: wgpu::Buffer,
    staged: Vec<u8>,
    alignment: u64,
    encoder: Option<wgpu::CommandEncoder>,
    pass: Option<wgpu::ComputePass<'static>>,
    open_frames: usize,
    bind_groups: HashMap<BindKey, wgpu::BindGroup>,
    pub(crate) counters: GpuCounters,
    pub(crate) profiler: Option<Profiler>,
}

impl std::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder")
            .field("open_frames", &self.open_frames)
            .field("staged_bytes", &self.staged.len())
            .field("cached_bind_groups", &self.bind_groups.len())
            .field("counters", &self.counters)
            .finish_non_exhaustive()
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        // A pass must end before its encoder goes.
        self.pass = None;
    }
}

impl Recorder {
    pub(crate) fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        let arena = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("uniforms"),
            size: UNIFORM_ARENA_BYTES,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            device: device.clone(),
            queue: queue.clone(),
            arena,
            staged: Vec::new(),
            alignment: u64::from(device.limits().min_uniform_buffer_offset_alignment.max(16)),
            encoder: None,
            pass: None,
            open_frames: 0,
            bind_groups: HashMap::new(),
            counters: GpuCounters::default(),
            profiler: None,
        }
    }

    /// True when commands wait for a submit.
    pub(crate) fn pending(&self) -> bool {
        self.encoder.is_some()
    }

    pub(crate) fn open_frame(&mut self) {
        self.open_frames += 1;
    }

    /// Closes a frame; true when it was the outermost (time to submit).
    pub(crate) fn close_frame(&mut self) -> bool {
        self.open_frames = self.open_frames.saturating_sub(1);
        self.open_frames == 0
    }

    pub(crate) fn in_frame(&self) -> bool {
        self.open_frames > 0
    }

    /// The encoder, with any compute pass ended.
    pub(crate) fn encoder(&mut self) -> &mut wgpu::CommandEncoder {
        self.pass = None;
        let device = &self.device;
        self.encoder.get_or_insert_with(|| device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("dynview") }))
    }

    /// Ends the compute pass (the next dispatch begins another).
    pub(crate) fn end_pass(&mut self) {
        self.pass = None;
    }

    /// Submits what was recorded, with its uniforms.
    pub(crate) fn flush(&mut self) {
        let queue = &self.queue;
        self.pass = None;
        if let Some(encoder) = self.encoder.take() {
            if !self.staged.is_empty() {
                queue.write_buffer(&self.arena, 0, &self.staged);
                self.staged.clear();
            }
            queue.submit([encoder.finish()]);
            self.counters.submits += 1;
        }
    }

    /// Records `sequence` dispatches of `kernel` over `groups` workgroups, the `i`-th with
    /// uniform block `uniforms[sequence[i]]` (all of one size) and the storage `buffers`.
    pub(crate) fn dispatch(
        &mut self,
        kernel: &DispatchTarget<'_>,
        uniforms: &[&[u8]],
        sequence: &[usize],
        buffers: &[&wgpu::Buffer],
        groups: (u32, u32, u32),
    ) {
        let uniform_size = uniforms.iter().map(|u| u.len() as u64).max().unwrap_or(0).next_multiple_of(16).max(16);
        let slot = uniform_size.next_multiple_of(self.alignment);
        if self.staged.len() as u64 + slot * uniforms.len() as u64 > UNIFORM_ARENA_BYTES {
            self.flush();
        }
        let offsets: Vec<u32> = uniforms
            .iter()
            .map(|bytes| {
                let offset = (self.staged.len() as u64).next_multiple_of(self.alignment);
                self.staged.resize(offset as usize, 0);
                self.staged.extend_from_slice(bytes);
                self.staged.resize((offset + uniform_size) as usize, 0);
                self.counters.uniform_bytes += slot;
                offset as u32
            })
            .collect();
        let key = BindKey { kernel: kernel.id, uniform_size, buffers: buffers.iter().map(|&b| b.clone()).collect() };
        if self.bind_groups.len() >= BIND_GROUP_CACHE && !self.bind_groups.contains_key(&key) {
            self.bind_groups.clear();
        }
        let (device, arena, created) = (&self.device, &self.arena, &mut self.counters.bind_groups_created);
        let bind_group = self
            .bind_groups
            .entry(key)
            .or_insert_with(|| {
                let mut entries = vec![wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: arena,
                        offset: 0,
                        size: std::num::NonZeroU64::new(uniform_size),
                    }),
                }];
                for (i, b) in buffers.iter().enumerate() {
                    entries.push(wgpu::BindGroupEntry { binding: i as u32 + 1, resource: b.as_entire_binding() });
                }
                *created += 1;
                device.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: kernel.layout, entries: &entries })
            })
            .clone();
        // While profiling, every dispatch call gets its own pass with timestamps at its ends.
        let profiled = self.profiler.as_mut().map(|p| p.next_pass(&self.device));
        if profiled.is_some() {
            self.pass = None;
        }
        if self.pass.is_none() {
            let timestamp_writes = profiled.as_ref().map(|(query_set, first)| wgpu::ComputePassTimestampWrites {
                query_set,
                beginning_of_pass_write_index: Some(*first),
                end_of_pass_write_index: Some(first + 1),
            });
            let encoder = self.encoder();
            let pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes }).forget_lifetime();
            self.pass = Some(pass);
            self.counters.passes += 1;
        }
        let Some(pass) = self.pass.as_mut() else { return };
        pass.set_pipeline(kernel.pipeline);
        for &i in sequence {
            pass.set_bind_group(0, &bind_group, &[offsets[i]]);
            pass.dispatch_workgroups(groups.0, groups.1, groups.2);
        }
        self.counters.dispatches += sequence.len() as u64;
        let bound: u64 = buffers.iter().map(|b| b.size()).sum();
        self.counters.bytes_bound += bound * sequence.len() as u64;
        if let Some(profiler) = self.profiler.as_mut() {
            profiler.add_bytes(bound * sequence.len() as u64);
        }
        if profiled.is_some() {
            self.pass = None;
        }
    }
}
