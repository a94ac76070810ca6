//! A scene package opened in the browser: the manifest and clouds index read at open, each
//! time step's cloud and frames fetched on demand and kept, decoded, in a cache with a memory
//! budget (least recently used steps go first).

use std::cell::{Cell, RefCell};
use std::rc::Rc;

use dynview_core::render::{InputView, TimeStepInputs};
use dynview_core::scene::cloud::{self, CloudIndex};
use dynview_core::scene::limits::{MAX_FRAME_FILE_BYTES, MAX_MANIFEST_BYTES};
use dynview_core::scene::manifest::MANIFEST_FILE;
use dynview_core::scene::{Manifest, decode_frame};

use crate::source::{ReadError, Source};

/// Default memory budget of decoded time steps (about five steps of six 960x540 cameras).
pub const DEFAULT_CACHE_BUDGET_BYTES: usize = 256 << 20;

/// Decoded inputs of one time step and their size in memory.
struct CachedStep {
    t: u32,
    inputs: Rc<TimeStepInputs>,
    bytes: usize,
}

/// Decoded time steps, least recently used first.
struct StepCache {
    steps: Vec<CachedStep>,
    budget_bytes: usize,
}

impl StepCache {
    fn get(&mut self, t: u32) -> Option<Rc<TimeStepInputs>> {
        let i = self.steps.iter().position(|s| s.t == t)?;
        let step = self.steps.remove(i);
        let inputs = step.inputs.clone();
        self.steps.push(step);
        Some(inputs)
    }

    fn insert(&mut self, t: u32, inputs: Rc<TimeStepInputs>) {
        self.steps.retain(|s| s.t != t);
        self.steps.push(CachedStep { t, bytes: inputs_bytes(&inputs), inputs });
        // Evict the least recently used steps, always keeping the newest one.
        while self.steps.len() > 1 && self.used_bytes() > self.budget_bytes {
            self.steps.remove(0);
        }
    }

    fn used_bytes(&self) -> usize {
        self.steps.iter().map(|s| s.bytes).sum()
    }
}

/// Bytes held by decoded inputs (pyramids of f32 RGB, cloud).
fn inputs_bytes(inputs: &TimeStepInputs) -> usize {
    let pixels: usize = inputs.views.iter().flat_map(|v| v.levels.iter()).map(|l| l.data.len()).sum();
    pixels * std::mem::size_of::<[f32; 3]>() + inputs.cloud.len() * 15
}

/// Counters of what was read, for loading bars.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct LoadStats {
    /// Bytes read from the source so far (all files).
    pub bytes_read: u64,
    /// Frame files read so far.
    pub frames_read: u64,
}

/// An opened scene package.
pub struct RemoteScene {
    source: Source,
    manifest: Manifest,
    cloud_index: CloudIndex,
    cache: RefCell<StepCache>,
    stats: Cell<LoadStats>,
}

fn invalid(e: impl std::fmt::Display) -> ReadError {
    ReadError(e.to_string())
}

impl RemoteScene {
    /// Reads and validates `scene.json` and the clouds index.
    pub async fn open(source: Source) -> Result<Self, ReadError> {
        let stats = Cell::new(LoadStats::default());
        let count = |n: usize| {
            let mut s = stats.get();
            s.bytes_read += n as u64;
            stats.set(s);
        };
        let manifest_bytes = source.start(MANIFEST_FILE, None, MAX_MANIFEST_BYTES)?.bytes().await?;
        count(manifest_bytes.len());
        let manifest = Manifest::from_json_slice(&manifest_bytes, &source.display_name(MANIFEST_FILE)).map_err(invalid)?;
        let clouds_file = manifest.clouds.file.clone();
        let clouds_name = source.display_name(&clouds_file);
        let file_length = manifest.clouds.byte_length;
        if file_length < cloud::HEADER_BYTES as u64 {
            return Err(ReadError(format!("{clouds_name}: shorter than the {}-byte header", cloud::HEADER_BYTES)));
        }
        let header = source.start(&clouds_file, Some((0, cloud::HEADER_BYTES as u64)), cloud::HEADER_BYTES as u64)?.bytes().await?;
        count(header.len());
        let step_count = CloudIndex::peek_step_count(&header, &clouds_name).map_err(invalid)?;
        if step_count != manifest.time_step_count {
            return Err(ReadError(format!(
                "{clouds_name}: field `step_count`: {step_count} steps but scene.json has time_step_count {}",
                manifest.time_step_count
            )));
        }
        let index_length = cloud::index_byte_length(step_count);
        if index_length > file_length {
            return Err(ReadError(format!("{clouds_name}: field `steps`: file too short for the offset table")));
        }
        let index_bytes = source.start(&clouds_file, Some((0, index_length)), index_length)?.bytes().await?;
        count(index_bytes.len());
        let cloud_index = CloudIndex::parse(&index_bytes, file_length, &clouds_name).map_err(invalid)?;
        let cache = RefCell::new(StepCache { steps: Vec::new(), budget_bytes: DEFAULT_CACHE_BUDGET_BYTES });
        Ok(Self { source, manifest, cloud_index, cache, stats })
    }

    /// The validated manifest.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// What was read so far.
    pub fn stats(&self) -> LoadStats {
        self.stats.get()
    }

    /// Sets the memory budget of decoded steps (evicting at the next insertion).
    pub fn set_cache_budget(&self, bytes: usize) {
        self.cache.borrow_mut().budget_bytes = bytes;
    }

    /// Drops every decoded step (their pyramid depth no longer matches the parameters).
    pub fn clear_cache(&self) {
        self.cache.borrow_mut().steps.clear();
    }

    /// Bytes held by decoded steps now.
    pub fn cache_used_bytes(&self) -> usize {
        self.cache.borrow().used_bytes()
    }

    /// The inputs of step `t` when they are cached.
    pub fn cached(&self, t: u32) -> Option<Rc<TimeStepInputs>> {
        self.cache.borrow_mut().get(t)
    }

    /// The inputs of step `t`, read and decoded unless cached. `levels` is the pyramid depth
    /// to build; `progress(stats, frames_done, frames_total)` follows the reads.
    pub async fn load_step(
        &self,
        t: u32,
        levels: usize,
        mut progress: impl FnMut(LoadStats, u32, u32),
    ) -> Result<Rc<TimeStepInputs>, ReadError> {
        if t >= self.manifest.time_step_count {
            return Err(ReadError(format!("time step {t} out of range: the scene has {}", self.manifest.time_step_count)));
        }
        if let Some(inputs) = self.cached(t) {
            return Ok(inputs);
        }
        let count = |n: usize, frames: u64| {
            let mut s = self.stats.get();
            s.bytes_read += n as u64;
            s.frames_read += frames;
            self.stats.set(s);
        };
        let entry = self.cloud_index.steps[t as usize];
        let clouds_file = &self.manifest.clouds.file;
        // Start every read before awaiting any, so they are in flight together.
        let cloud_read = self.source.start(clouds_file, Some((entry.offset, entry.offset + entry.byte_length())), entry.byte_length())?;
        let cameras = self.manifest.cameras.len();
        let frame_reads = (0..cameras)
            .map(|c| self.source.start(&self.manifest.frame_relative_path(c, t), None, MAX_FRAME_FILE_BYTES))
            .collect::<Result<Vec<_>, _>>()?;
        let block = cloud_read.bytes().await?;
        count(block.len(), 0);
        let cloud = self.cloud_index.decode_step(t as usize, &block, &self.source.display_name(clouds_file)).map_err(invalid)?;
        let total = cameras as u32;
        progress(self.stats.get(), 0, total);
        let mut views = Vec::with_capacity(cameras);
        for (c, read) in frame_reads.into_iter().enumerate() {
            let bytes = read.bytes().await?;
            count(bytes.len(), 1);
            let entry = &self.manifest.cameras[c];
            let name = self.source.display_name(&self.manifest.frame_relative_path(c, t));
            let image = decode_frame(&bytes, self.manifest.frame_format, entry.width, entry.height, &name).map_err(invalid)?;
            views.push(InputView::new(self.manifest.camera_at(c, t), image, levels));
            progress(self.stats.get(), c as u32 + 1, total);
        }
        let inputs = Rc::new(TimeStepInputs { cloud, views });
        self.cache.borrow_mut().insert(t, inputs.clone());
        Ok(inputs)
    }
}
