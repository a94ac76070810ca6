//! GPU time per stage from timestamp queries: while profiling is on, every compute pass writes a
//! timestamp at its start and end, labelled with the renderer's current level and stage
//! ([`Profiler`], kept by the recorder); the sums per label ([`StageTime`]) are made from the
//! ticks read back at the end of the frame (`profile.rs`).

#[cfg(not(target_family = "wasm"))]
use std::collections::BTreeMap;

/// Queries per query set (wgpu allows at most 4096 per set; a frame takes a few sets).
const QUERIES_PER_SET: u32 = 4096;

/// GPU milliseconds of one stage of one pyramid level, summed over its compute passes.
#[derive(Clone, Debug, PartialEq)]
pub struct StageTime {
    /// Pyramid level (0 = finest).
    pub level: usize,
    /// Stage name (`splat`, `push-pull`, `warp`, `temporal`, `weights`, `depth system`,
    /// `depth solve`, `color system`, `color solve`).
    pub stage: &'static str,
    /// GPU time, milliseconds.
    pub ms: f64,
    /// Compute passes it took.
    pub passes: usize,
    /// Bytes of the storage buffers its dispatches bound, summed over the dispatches: an upper
    /// bound of the memory traffic (a kernel reads or writes each bound buffer at most about
    /// once; most read every byte), for bandwidth against the time.
    pub bytes_bound: u64,
}

/// The query sets of a profiled frame and the label of each pass.
#[derive(Debug)]
pub(crate) struct Profiler {
    sets: Vec<wgpu::QuerySet>,
    /// (level, stage) of each pass, in order; pass `i` wrote queries `2i` and `2i + 1`.
    labels: Vec<(usize, &'static str)>,
    /// Bytes bound by each pass's dispatches.
    bytes: Vec<u64>,
    current: (usize, &'static str),
}

impl Profiler {
    pub(crate) fn new() -> Self {
        Self { sets: Vec::new(), labels: Vec::new(), bytes: Vec::new(), current: (0, "other") }
    }

    pub(crate) fn set_stage(&mut self, level: usize, stage: &'static str) {
        self.current = (level, stage);
    }

    /// The query set and first index for the next pass (two queries: start and end).
    pub(crate) fn next_pass(&mut self, device: &wgpu::Device) -> (wgpu::QuerySet, u32) {
        let index = self.labels.len() as u32 * 2;
        let set = (index / QUERIES_PER_SET) as usize;
        if set == self.sets.len() {
            self.sets.push(device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("stage timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: QUERIES_PER_SET,
            }));
        }
        self.labels.push(self.current);
        self.bytes.push(0);
        (self.sets[set].clone(), index % QUERIES_PER_SET)
    }

    /// Counts `bytes` bound by a dispatch of the current pass.
    pub(crate) fn add_bytes(&mut self, bytes: u64) {
        if let Some(last) = self.bytes.last_mut() {
            *last += bytes;
        }
    }

    /// Each query set with the number of its queries that passes wrote (from the first).
    #[cfg(not(target_family = "wasm"))]
    pub(crate) fn written_queries(&self) -> Vec<(&wgpu::QuerySet, u32)> {
        let mut remaining = self.labels.len() as u32 * 2;
        self.sets
            .iter()
            .map(|set| {
                let count = remaining.min(QUERIES_PER_SET);
                remaining -= count;
                (set, count)
            })
            .collect()
    }

    /// Sums the passes' times per label from their `ticks` (two per pass, start and end, in
    /// the order of [`Self::written_queries`]) at `period_ns` nanoseconds per tick.
    #[cfg(not(target_family = "wasm"))]
    pub(crate) fn stage_times(self, ticks: &[u64], period_ns: f64) -> Vec<StageTime> {
        let mut sums: BTreeMap<(usize, &'static str), (f64, usize, u64)> = BTreeMap::new();
        for (pass, label) in self.labels.iter().enumerate() {
            let (start, end) = (ticks[2 * pass], ticks[2 * pass + 1]);
            let entry = sums.entry(*label).or_default();
            entry.0 += end.saturating_sub(start) as f64 * period_ns / 1e6;
            entry.1 += 1;
            entry.2 += self.bytes[pass];
        }
        sums.into_iter().map(|((level, stage), (ms, passes, bytes_bound))| StageTime { level, stage, ms, passes, bytes_bound }).collect()
    }
}
