//! Profiling a context's work: [`GpuContext::start_profile`] has every compute pass write
//! timestamps, [`GpuContext::set_stage`] labels the passes that follow with a level and stage,
//! and [`GpuContext::finish_profile`] resolves the timestamp queries, reads them back and sums
//! them per label ([`StageTime`]).

#[cfg(not(target_family = "wasm"))]
use crate::device::error::GpuError;
#[cfg(not(target_family = "wasm"))]
use crate::device::readback::read_bytes;
#[cfg(not(target_family = "wasm"))]
use crate::device::timestamps::StageTime;
use crate::device::{context::GpuContext, timestamps::Profiler};

impl GpuContext {
    /// Starts timing every compute pass (timestamp queries) until [`Self::finish_profile`];
    /// false when the device has no timestamp queries. While profiling, every dispatch call
    /// gets its own pass.
    pub fn start_profile(&self) -> bool {
        if !self.device.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return false;
        }
        let mut recorder = self.recorder();
        recorder.end_pass();
        recorder.profiler = Some(Profiler::new());
        true
    }

    /// Stops timing and returns GPU milliseconds per level and stage since
    /// [`Self::start_profile`] (empty when it was not started). Blocks until the GPU is done.
    #[cfg(not(target_family = "wasm"))]
    pub fn finish_profile(&self) -> Result<Vec<StageTime>, GpuError> {
        let profiler = {
            let mut recorder = self.recorder();
            recorder.flush();
            recorder.profiler.take()
        };
        profiler.map_or(Ok(Vec::new()), |p| self.stage_times(p))
    }

    /// Labels the compute passes that follow (while profiling).
    pub(crate) fn set_stage(&self, level: usize, stage: &'static str) {
        if let Some(p) = self.recorder().profiler.as_mut() {
            p.set_stage(level, stage);
        }
    }

    /// Resolves `profiler`'s queries and sums them per label (blocks until the GPU is done).
    #[cfg(not(target_family = "wasm"))]
    fn stage_times(&self, profiler: Profiler) -> Result<Vec<StageTime>, GpuError> {
        let period_ns = f64::from(self.queue.get_timestamp_period());
        let mut ticks: Vec<u64> = Vec::new();
        for (set, count) in profiler.written_queries() {
            let size = u64::from(count) * 8;
            let resolved = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("resolved timestamps"),
                size,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let mut encoder = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("resolve timestamps") });
            encoder.resolve_query_set(set, 0..count, &resolved, 0);
            self.queue.submit([encoder.finish()]);
            let bytes = pollster::block_on(read_bytes(self, &resolved, size))?;
            ticks.extend(bytes.chunks_exact(8).map(|b| u64::from_le_bytes(b.try_into().unwrap_or_default())));
        }
        Ok(profiler.stage_times(&ticks, period_ns))
    }
}
