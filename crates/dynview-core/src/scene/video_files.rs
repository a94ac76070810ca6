//! A video package's frames on a file system: writing each camera's stream while the package
//! is staged, and reading frames back with a cache of decoded groups.

use std::collections::{HashMap, VecDeque};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;
use std::sync::{Arc, Mutex};

use super::error::{SceneError, SceneResult};
use super::ffmpeg::{VideoEncoder, VideoSettings, decode_vp9};
use super::limits::MAX_FRAME_FILE_BYTES;
use super::manifest::{FRAMES_DIR, Manifest};
use super::video::{CameraFrames, FrameIndex, index_byte_length};
use super::yuv::{Yuv420, frame_bytes};

/// Bytes of decoded frames a reader keeps (a group of 30 frames of six 960x540 cameras).
pub const DECODED_CACHE_BYTES: usize = 256 << 20;
/// Most bytes of frames one decode returns: a longer group is decoded in parts.
const DECODE_BATCH_BYTES: usize = 64 << 20;

/// Every camera's stream being written, each behind its own lock (cameras in parallel, each
/// camera's frames in time order).
#[derive(Debug)]
pub struct VideoWriter {
    encoders: Vec<Mutex<VideoEncoder>>,
}

impl VideoWriter {
    /// Starts one encoder per camera of `manifest`, writing `frames/<camera>.ivf` under `dir`.
    pub fn start(dir: &Path, manifest: &Manifest, settings: VideoSettings) -> SceneResult<Self> {
        let encoders = (0..manifest.cameras.len())
            .map(|c| {
                let entry = &manifest.cameras[c];
                VideoEncoder::start(&dir.join(manifest.video_relative_path(c)), entry.width, entry.height, manifest.fps, settings)
                    .map(Mutex::new)
            })
            .collect::<SceneResult<_>>()?;
        Ok(Self { encoders })
    }

    /// Appends frame `t` of `camera`, which must be the camera's next frame.
    pub fn push(&self, camera: usize, t: u32, image: &image::RgbImage, file: &str) -> SceneResult<()> {
        let mut encoder =
            self.encoders[camera].lock().map_err(|_| SceneError::invalid(file, "(video)", "an earlier write of this camera failed"))?;
        if encoder.frames_written() != t {
            return Err(SceneError::invalid(
                file,
                "(frame order)",
                format!(
                    "frame {t} written, but the video's next frame is {}: video frames are written in time order",
                    encoder.frames_written()
                ),
            ));
        }
        encoder.push(&Yuv420::from_rgb8(image))
    }

    /// Ends every stream and returns the frame index.
    pub fn finish(self) -> SceneResult<FrameIndex> {
        let cameras = self
            .encoders
            .into_iter()
            .map(|m| m.into_inner().map_err(|_| SceneError::invalid(FRAMES_DIR, "(video)", "an earlier write failed"))?.finish())
            .collect::<SceneResult<Vec<CameraFrames>>>()?;
        Ok(FrameIndex { cameras })
    }
}

/// Decoded frames by `(camera, t)`, oldest first out.
#[derive(Debug, Default)]
struct DecodedCache {
    frames: HashMap<(usize, u32), Arc<Yuv420>>,
    order: VecDeque<(usize, u32)>,
    bytes: usize,
}

impl DecodedCache {
    fn insert(&mut self, key: (usize, u32), frame: Yuv420) {
        let size = frame_bytes(frame.width, frame.height);
        if self.frames.insert(key, Arc::new(frame)).is_none() {
            self.order.push_back(key);
            self.bytes += size;
        }
        while self.bytes > DECODED_CACHE_BYTES && self.order.len() > 1 {
            if let Some(old) = self.order.pop_front()
                && let Some(f) = self.frames.remove(&old)
            {
                self.bytes -= frame_bytes(f.width, f.height);
            }
        }
    }
}

/// The frames of an opened video package.
#[derive(Debug)]
pub struct VideoFrames {
    index: FrameIndex,
    cache: Mutex<DecodedCache>,
}

impl VideoFrames {
    /// Reads and checks `frames.idx` and the size of every camera's video.
    pub fn open(root: &Path, manifest: &Manifest) -> SceneResult<Self> {
        let Some(entry) = &manifest.frames_index else {
            return Err(SceneError::invalid(super::manifest::MANIFEST_FILE, "frames_index", "missing"));
        };
        let path = root.join(&entry.file);
        let name = path.display().to_string();
        let expected = index_byte_length(manifest.cameras.len(), manifest.time_step_count);
        let length = std::fs::metadata(&path).map_err(|e| SceneError::io(&path, e))?.len();
        if length != expected || length != entry.byte_length {
            return Err(SceneError::invalid(
                &name,
                "(file)",
                format!(
                    "{length} bytes; scene.json says {} and {} cameras x {} steps need {expected}",
                    entry.byte_length,
                    manifest.cameras.len(),
                    manifest.time_step_count
                ),
            ));
        }
        let bytes = std::fs::read(&path).map_err(|e| SceneError::io(&path, e))?;
        let index = FrameIndex::parse(&bytes, manifest.cameras.len(), manifest.time_step_count, &name)?;
        for (c, camera) in index.cameras.iter().enumerate() {
            let video = root.join(manifest.video_relative_path(c));
            let length = std::fs::metadata(&video).map_err(|e| SceneError::io(&video, e))?.len();
            if length != camera.ivf_byte_length {
                return Err(SceneError::invalid(
                    video.display().to_string(),
                    "(file)",
                    format!("{length} bytes, {name} says {}", camera.ivf_byte_length),
                ));
            }
        }
        Ok(Self { index, cache: Mutex::new(DecodedCache::default()) })
    }

    /// The frame index.
    pub fn index(&self) -> &FrameIndex {
        &self.index
    }

    /// Frame `t` of `camera`, decoded (with the frames after it in its group, which playback
    /// wants next) unless cached.
    pub fn read(&self, root: &Path, manifest: &Manifest, camera: usize, t: u32) -> SceneResult<Arc<Yuv420>> {
        if let Some(frame) = self.cache.lock().ok().and_then(|c| c.frames.get(&(camera, t)).cloned()) {
            return Ok(frame);
        }
        let entry = &manifest.cameras[camera];
        let per_batch = (DECODE_BATCH_BYTES / frame_bytes(entry.width, entry.height)).max(1) as u32;
        let frames = &self.index.cameras[camera];
        let next_key = (t + 1..manifest.time_step_count).find(|&k| frames.frames[k as usize].key).unwrap_or(manifest.time_step_count);
        let last = (next_key - 1).min(t + per_batch - 1);
        let decoded = self.decode(root, manifest, camera, last, t)?;
        let mut cache = self.cache.lock().map_err(|_| SceneError::invalid(FRAMES_DIR, "(video)", "a decode failed"))?;
        let mut wanted = None;
        for (i, frame) in decoded.into_iter().enumerate() {
            let at = t + i as u32;
            if at == t {
                wanted = Some(Arc::new(frame.clone()));
            }
            cache.insert((camera, at), frame);
        }
        wanted.ok_or_else(|| SceneError::invalid(FRAMES_DIR, "(video)", "nothing decoded"))
    }

    /// Decodes `camera`'s frames from the keyframe of `last` to `last`, keeping those from
    /// `keep_from` on.
    fn decode(&self, root: &Path, manifest: &Manifest, camera: usize, last: u32, keep_from: u32) -> SceneResult<Vec<Yuv420>> {
        let path = root.join(manifest.video_relative_path(camera));
        let name = path.display().to_string();
        let frames = &self.index.cameras[camera];
        let span = frames.span_to(last, None);
        let length = span.bytes.1 - span.bytes.0;
        if length > MAX_FRAME_FILE_BYTES {
            return Err(SceneError::invalid(
                &name,
                format!("frames {}..={last}", span.first),
                format!("{length} bytes, more than the limit of {MAX_FRAME_FILE_BYTES}"),
            ));
        }
        let mut file = File::open(&path).map_err(|e| SceneError::io(&path, e))?;
        file.seek(SeekFrom::Start(span.bytes.0)).map_err(|e| SceneError::io(&path, e))?;
        let mut bytes = vec![0u8; length as usize];
        file.read_exact(&mut bytes).map_err(|e| SceneError::io(&path, e))?;
        let payloads = frames.payloads(&span, &bytes, &name)?;
        let entry = &manifest.cameras[camera];
        decode_vp9(entry.width, entry.height, &payloads, (keep_from - span.first) as usize, &path)
    }

    /// Decodes every frame of every camera, group by group (the full check of `dynview info`);
    /// `progress(done, total)` counts frames.
    pub fn verify(&self, root: &Path, manifest: &Manifest, mut progress: impl FnMut(u64, u64)) -> SceneResult<()> {
        let steps = manifest.time_step_count;
        let total = manifest.cameras.len() as u64 * u64::from(steps);
        let mut done = 0;
        for (c, frames) in self.index.cameras.iter().enumerate() {
            let keys: Vec<u32> = (0..steps).filter(|&t| frames.frames[t as usize].key).chain([steps]).collect();
            for group in keys.windows(2) {
                let decoded = self.decode(root, manifest, c, group[1] - 1, group[1] - 1)?;
                debug_assert_eq!(decoded.len(), 1);
                done += u64::from(group[1] - group[0]);
                progress(done, total);
            }
        }
        Ok(())
    }
}
