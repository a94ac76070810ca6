//! A scene package opened in the browser: the manifest and clouds index read at open, each
//! time step's cloud and frames fetched on demand and kept, decoded, in a cache with a memory
//! budget (least recently used steps go first).

use std::cell::{Cell, RefCell};
use std::rc::Rc;

use dynview_core::points::PointCloud;
use dynview_core::raster::RgbRaster;
use dynview_core::render::{InputView, PlatePyramids, TimeStepInputs};
use dynview_core::scene::cloud::{self, CloudIndex};
use dynview_core::scene::limits::{MAX_FRAME_FILE_BYTES, MAX_MANIFEST_BYTES};
use dynview_core::scene::manifest::{FrameFormat, MANIFEST_FILE};
use dynview_core::scene::video::{FrameIndex, index_byte_length};
use dynview_core::scene::yuv::{PlaneLayout, Yuv420};
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
        self.steps.push(CachedStep { t, bytes: inputs.decoded_bytes(), inputs });
        // Evict the least recently used steps, always keeping the newest one.
        while self.steps.len() > 1 && self.used_bytes() > self.budget_bytes {
            self.steps.remove(0);
        }
    }

    fn used_bytes(&self) -> usize {
        self.steps.iter().map(|s| s.bytes).sum()
    }
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
    /// The frame index of a video package.
    video: Option<FrameIndex>,
    /// The static cloud the steps borrow from (empty in a version 1 clouds file).
    statics: Rc<PointCloud>,
    /// Per camera, its background plate (color-balanced) when the package has one.
    plates: Vec<Option<RgbRaster>>,
    /// The plates as pyramids, built once and shared by every step's inputs.
    plate_pyramids: PlatePyramids,
}

/// The compressed frames a decoder needs to show one frame of one camera's video.
#[derive(Debug)]
pub struct VideoChunks {
    /// Time step of the first chunk (a keyframe, unless it continues the decoder's group).
    pub first: u32,
    /// One VP9 frame per time step `first..=t`.
    pub chunks: Vec<Vec<u8>>,
    /// Whether each chunk is a keyframe.
    pub keys: Vec<bool>,
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
        let (version, step_count) = CloudIndex::peek(&header, &clouds_name).map_err(invalid)?;
        if step_count != manifest.time_step_count {
            return Err(ReadError(format!(
                "{clouds_name}: field `step_count`: {step_count} steps but scene.json has time_step_count {}",
                manifest.time_step_count
            )));
        }
        let index_length = cloud::index_byte_length(version, step_count);
        if index_length > file_length {
            return Err(ReadError(format!("{clouds_name}: field `steps`: file too short for the offset table")));
        }
        let index_bytes = source.start(&clouds_file, Some((0, index_length)), index_length)?.bytes().await?;
        count(index_bytes.len());
        let cloud_index = CloudIndex::parse(&index_bytes, file_length, &clouds_name).map_err(invalid)?;
        // A version 2 file's static cloud: read once, here.
        let statics = match cloud_index.static_block {
            Some(entry) => {
                let range = (entry.offset, entry.offset + entry.byte_length());
                let block = source.start(&clouds_file, Some(range), entry.byte_length())?.bytes().await?;
                count(block.len());
                Rc::new(cloud_index.decode_static(&block, &clouds_name).map_err(invalid)?)
            }
            None => Rc::default(),
        };
        let video = match &manifest.frames_index {
            Some(entry) => {
                let expected = index_byte_length(manifest.cameras.len(), manifest.time_step_count);
                let name = source.display_name(&entry.file);
                if entry.byte_length != expected {
                    return Err(ReadError(format!(
                        "{name}: {} bytes in scene.json, but the cameras and steps need {expected}",
                        entry.byte_length
                    )));
                }
                let bytes = source.start(&entry.file, None, expected)?.bytes().await?;
                count(bytes.len());
                Some(FrameIndex::parse(&bytes, manifest.cameras.len(), manifest.time_step_count, &name).map_err(invalid)?)
            }
            None => None,
        };
        // The background plates: read once, here.
        let mut plates = Vec::with_capacity(manifest.cameras.len());
        for (c, entry) in manifest.cameras.iter().enumerate() {
            if !entry.plate {
                plates.push(None);
                continue;
            }
            let file = manifest.plate_relative_path(c);
            let bytes = source.start(&file, None, MAX_FRAME_FILE_BYTES)?.bytes().await?;
            count(bytes.len());
            let plate = decode_frame(&bytes, FrameFormat::Jpeg, entry.width, entry.height, &source.display_name(&file)).map_err(invalid)?;
            plates.push(Some(manifest.balanced_plate(c, plate)));
        }
        let cache = RefCell::new(StepCache { steps: Vec::new(), budget_bytes: DEFAULT_CACHE_BUDGET_BYTES });
        Ok(Self { source, manifest, cloud_index, cache, stats, video, statics, plates, plate_pyramids: PlatePyramids::default() })
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

    fn count(&self, n: usize, frames: u64) {
        let mut s = self.stats.get();
        s.bytes_read += n as u64;
        s.frames_read += frames;
        self.stats.set(s);
    }

    fn check_step(&self, t: u32) -> Result<(), ReadError> {
        if t >= self.manifest.time_step_count {
            return Err(ReadError(format!("time step {t} out of range: the scene has {}", self.manifest.time_step_count)));
        }
        Ok(())
    }

    /// Reads and decodes the cloud of step `t`.
    /// Camera `c`'s input view at step `t`, with its plate when it has one.
    fn input_view(&self, c: usize, t: u32, image: RgbRaster, levels: usize) -> InputView {
        let view = self.manifest.input_view(c, t, image, levels);
        let Ok(pyramid) = self.plate_pyramids.get_or_build(c, levels, || Ok::<_, std::convert::Infallible>(self.plates[c].clone()));
        match pyramid {
            Some(plate) => view.with_plate_pyramid(plate),
            None => view,
        }
    }

    /// How many of step `t`'s points (at the end of its cloud) are borrowed static points.
    fn static_points(&self, t: u32) -> usize {
        self.cloud_index.steps[t as usize].borrowed_count as usize
    }

    async fn load_cloud(&self, t: u32) -> Result<PointCloud, ReadError> {
        let entry = self.cloud_index.steps[t as usize];
        let clouds_file = &self.manifest.clouds.file;
        let block =
            self.source.start(clouds_file, Some((entry.offset, entry.offset + entry.byte_length())), entry.byte_length())?.bytes().await?;
        self.count(block.len(), 0);
        self.cloud_index.decode_step(t as usize, &block, Some(&self.statics), &self.source.display_name(clouds_file)).map_err(invalid)
    }

    /// Whether the frames are video (decoded by the page with WebCodecs and handed over with
    /// [`RemoteScene::load_step_from_frames`]) rather than image files.
    pub fn is_video(&self) -> bool {
        self.video.is_some()
    }

    /// The VP9 frames that show frame `t` of `camera`: from its keyframe, or from `after + 1`
    /// when the caller's decoder has just shown frame `after` of the same group. One range read.
    pub async fn video_chunks(&self, camera: usize, t: u32, after: Option<u32>) -> Result<VideoChunks, ReadError> {
        self.check_step(t)?;
        let (Some(index), Some(_)) = (&self.video, self.manifest.cameras.get(camera)) else {
            return Err(ReadError(format!("camera {camera} has no video in this scene")));
        };
        let frames = &index.cameras[camera];
        let span = frames.span_to(t, after);
        let file = self.manifest.video_relative_path(camera);
        let length = span.bytes.1 - span.bytes.0;
        if length > MAX_FRAME_FILE_BYTES {
            return Err(ReadError(format!(
                "{}: frames {}..={t} take {length} bytes, more than the limit of {MAX_FRAME_FILE_BYTES}",
                self.source.display_name(&file),
                span.first
            )));
        }
        let bytes = self.source.start(&file, Some(span.bytes), length)?.bytes().await?;
        self.count(bytes.len(), 0);
        let payloads = frames.payloads(&span, &bytes, &self.source.display_name(&file)).map_err(invalid)?;
        Ok(VideoChunks {
            first: span.first,
            chunks: payloads.into_iter().map(<[u8]>::to_vec).collect(),
            keys: (span.first..=t).map(|i| frames.frames[i as usize].key).collect(),
        })
    }

    /// Step `t` of a video package from its decoded frames, one per camera (`I420` or `NV12`
    /// planes, tight), and its cloud (read here), unless cached.
    pub async fn load_step_from_frames(
        &self,
        t: u32,
        levels: usize,
        frames: Vec<(PlaneLayout, Vec<u8>)>,
    ) -> Result<Rc<TimeStepInputs>, ReadError> {
        self.check_step(t)?;
        if let Some(inputs) = self.cached(t) {
            return Ok(inputs);
        }
        if frames.len() != self.manifest.cameras.len() {
            return Err(ReadError(format!("{} frames for {} cameras", frames.len(), self.manifest.cameras.len())));
        }
        let cloud = self.load_cloud(t).await?;
        let mut views = Vec::with_capacity(frames.len());
        for (c, (layout, bytes)) in frames.into_iter().enumerate() {
            let entry = &self.manifest.cameras[c];
            let yuv = Yuv420::from_bytes(entry.width, entry.height, layout, &bytes).ok_or_else(|| {
                ReadError(format!(
                    "{}: frame {t}: {} bytes decoded, a {}x{} frame has {}",
                    self.manifest.video_relative_path(c),
                    bytes.len(),
                    entry.width,
                    entry.height,
                    dynview_core::scene::yuv::frame_bytes(entry.width, entry.height)
                ))
            })?;
            self.count(0, 1);
            let image = RgbRaster::from_rgb8(&yuv.to_rgb8());
            views.push(self.input_view(c, t, image, levels));
        }
        let inputs = Rc::new(TimeStepInputs { cloud, views, static_points: self.static_points(t) });
        self.cache.borrow_mut().insert(t, inputs.clone());
        Ok(inputs)
    }

    /// The inputs of step `t` of an image package, read and decoded unless cached. `levels` is the pyramid depth
    /// to build; `progress(stats, frames_done, frames_total)` follows the reads.
    pub async fn load_step(
        &self,
        t: u32,
        levels: usize,
        mut progress: impl FnMut(LoadStats, u32, u32),
    ) -> Result<Rc<TimeStepInputs>, ReadError> {
        self.check_step(t)?;
        if let Some(inputs) = self.cached(t) {
            return Ok(inputs);
        }
        if self.is_video() {
            return Err(ReadError("the frames of this scene are video: decode them and hand them over (loadStepFrames)".into()));
        }
        let cameras = self.manifest.cameras.len();
        // Start every read before awaiting any, so they are in flight together.
        let cloud = self.load_cloud(t);
        let frame_reads = (0..cameras)
            .map(|c| self.source.start(&self.manifest.frame_relative_path(c, t), None, MAX_FRAME_FILE_BYTES))
            .collect::<Result<Vec<_>, _>>()?;
        let cloud = cloud.await?;
        let total = cameras as u32;
        progress(self.stats.get(), 0, total);
        let mut views = Vec::with_capacity(cameras);
        for (c, read) in frame_reads.into_iter().enumerate() {
            let bytes = read.bytes().await?;
            self.count(bytes.len(), 1);
            let entry = &self.manifest.cameras[c];
            let name = self.source.display_name(&self.manifest.frame_relative_path(c, t));
            let image = decode_frame(&bytes, self.manifest.frame_format, entry.width, entry.height, &name).map_err(invalid)?;
            views.push(self.input_view(c, t, image, levels));
            progress(self.stats.get(), c as u32 + 1, total);
        }
        let inputs = Rc::new(TimeStepInputs { cloud, views, static_points: self.static_points(t) });
        self.cache.borrow_mut().insert(t, inputs.clone());
        Ok(inputs)
    }
}
