//! Reading and writing scene packages on a file system.
//!
//! The writer builds the package in a hidden sibling folder ([`StagedDir`]) and renames it into place only
//! when complete, so a failed or interrupted write never leaves a half package and never
//! destroys what was there before.

use std::fs::{self, File};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::cloud::{self, CloudIndex, PointCloud};
use super::error::{SceneError, SceneResult};
use super::ffmpeg::{DEFAULT_KEYFRAME_INTERVAL, VideoSettings};
use super::limits::{MAX_FRAME_FILE_BYTES, MAX_MANIFEST_BYTES};
use super::manifest::{FRAMES_DIR, MANIFEST_FILE, Manifest};
use super::video::FrameIndex;
use super::video_files::{VideoFrames, VideoWriter};
use crate::camera::Camera;
use crate::fsutil::StagedDir;
use crate::raster::RgbRaster;

pub use super::frame::{JPEG_QUALITY, decode_frame, encode_frame};

/// An opened, validated scene package. Opening reads `scene.json` and the clouds index only;
/// clouds and frames are read on demand, one time step at a time.
#[derive(Debug)]
pub struct ScenePackage {
    root: PathBuf,
    manifest: Manifest,
    cloud_index: CloudIndex,
    /// The videos' index and decoded frames (video packages only).
    video: Option<VideoFrames>,
}

fn read_limited(path: &Path, limit: u64) -> SceneResult<Vec<u8>> {
    let file = File::open(path).map_err(|e| SceneError::io(path, e))?;
    let len = file.metadata().map_err(|e| SceneError::io(path, e))?.len();
    if len > limit {
        return Err(SceneError::invalid(path.display().to_string(), "(file)", format!("{len} bytes exceeds the limit of {limit}")));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(limit).read_to_end(&mut bytes).map_err(|e| SceneError::io(path, e))?;
    Ok(bytes)
}

impl ScenePackage {
    /// Opens and validates the package in folder `root`.
    pub fn open(root: impl AsRef<Path>) -> SceneResult<Self> {
        let root = root.as_ref().to_path_buf();
        let manifest_path = root.join(MANIFEST_FILE);
        let manifest_name = manifest_path.display().to_string();
        let bytes = read_limited(&manifest_path, MAX_MANIFEST_BYTES)?;
        let manifest = Manifest::from_json_slice(&bytes, &manifest_name)?;

        let clouds_path = root.join(&manifest.clouds.file);
        let clouds_name = clouds_path.display().to_string();
        let mut file = File::open(&clouds_path).map_err(|e| SceneError::io(&clouds_path, e))?;
        let file_length = file.metadata().map_err(|e| SceneError::io(&clouds_path, e))?.len();
        if file_length != manifest.clouds.byte_length {
            return Err(SceneError::invalid(
                &manifest_name,
                "clouds.byte_length",
                format!("says {} bytes but {} has {file_length}", manifest.clouds.byte_length, manifest.clouds.file),
            ));
        }
        let mut header = [0u8; cloud::HEADER_BYTES];
        file.read_exact(&mut header).map_err(|_| {
            SceneError::invalid(&clouds_name, "(header)", format!("file shorter than the {}-byte header", cloud::HEADER_BYTES))
        })?;
        let step_count = CloudIndex::peek_step_count(&header, &clouds_name)?;
        if step_count != manifest.time_step_count {
            return Err(SceneError::invalid(
                &clouds_name,
                "step_count",
                format!("{step_count} steps but scene.json has time_step_count {}", manifest.time_step_count),
            ));
        }
        let index_len = cloud::index_byte_length(step_count);
        if index_len > file_length {
            return Err(SceneError::invalid(&clouds_name, "steps", "file too short for the offset table"));
        }
        let mut index_bytes = header.to_vec();
        index_bytes.resize(index_len as usize, 0);
        file.read_exact(&mut index_bytes[cloud::HEADER_BYTES..]).map_err(|e| SceneError::io(&clouds_path, e))?;
        let cloud_index = CloudIndex::parse(&index_bytes, file_length, &clouds_name)?;
        let video = if manifest.frame_format.is_video() { Some(VideoFrames::open(&root, &manifest)?) } else { None };
        Ok(Self { root, manifest, cloud_index, video })
    }

    /// The package folder.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The validated manifest.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// The clouds index (point counts per step, quantisation bounds).
    pub fn cloud_index(&self) -> &CloudIndex {
        &self.cloud_index
    }

    /// Number of time steps.
    pub fn time_step_count(&self) -> u32 {
        self.manifest.time_step_count
    }

    /// Number of input cameras.
    pub fn camera_count(&self) -> usize {
        self.manifest.cameras.len()
    }

    /// The posed input camera `camera` at time step `t`.
    pub fn camera(&self, camera: usize, t: u32) -> SceneResult<Camera> {
        self.check_indices(camera, t)?;
        Ok(self.manifest.camera_at(camera, t))
    }

    fn check_indices(&self, camera: usize, t: u32) -> SceneResult<()> {
        if camera >= self.manifest.cameras.len() {
            return Err(SceneError::invalid(MANIFEST_FILE, "cameras", format!("camera {camera} out of range")));
        }
        if t >= self.manifest.time_step_count {
            return Err(SceneError::invalid(MANIFEST_FILE, "time_step_count", format!("time step {t} out of range")));
        }
        Ok(())
    }

    /// Reads and decodes the cloud of time step `t`, touching no other step's bytes.
    pub fn read_cloud(&self, t: u32) -> SceneResult<PointCloud> {
        let path = self.root.join(&self.manifest.clouds.file);
        let name = path.display().to_string();
        let Some(entry) = self.cloud_index.steps.get(t as usize).copied() else {
            return Err(SceneError::invalid(&name, "steps", format!("time step {t} out of range")));
        };
        let mut file = File::open(&path).map_err(|e| SceneError::io(&path, e))?;
        file.seek(SeekFrom::Start(entry.offset)).map_err(|e| SceneError::io(&path, e))?;
        let mut block = vec![0u8; entry.byte_length() as usize];
        file.read_exact(&mut block)
            .map_err(|_| SceneError::invalid(&name, format!("steps[{t}]"), "block truncated (file changed since it was opened?)"))?;
        self.cloud_index.decode_step(t as usize, &block, &name)
    }

    /// Path of the file holding the frame of `camera` at time step `t` (its video in a video
    /// package).
    pub fn frame_path(&self, camera: usize, t: u32) -> SceneResult<PathBuf> {
        self.check_indices(camera, t)?;
        if self.video.is_some() {
            return Ok(self.root.join(self.manifest.video_relative_path(camera)));
        }
        Ok(self.root.join(self.manifest.frame_relative_path(camera, t)))
    }

    /// The frame index of a video package.
    pub fn frame_index(&self) -> Option<&FrameIndex> {
        self.video.as_ref().map(VideoFrames::index)
    }

    /// Reads and decodes the input frame of `camera` at time step `t`, checking its size.
    pub fn read_frame(&self, camera: usize, t: u32) -> SceneResult<RgbRaster> {
        self.check_indices(camera, t)?;
        if let Some(video) = &self.video {
            let frame = video.read(&self.root, &self.manifest, camera, t)?;
            return Ok(RgbRaster::from_rgb8(&frame.to_rgb8()));
        }
        let path = self.frame_path(camera, t)?;
        let bytes = read_limited(&path, MAX_FRAME_FILE_BYTES)?;
        let entry = &self.manifest.cameras[camera];
        decode_frame(&bytes, self.manifest.frame_format, entry.width, entry.height, &path.display().to_string())
    }

    /// Reads only the header of a frame file and checks its dimensions (cheap validation; a
    /// video package's frames are checked by [`ScenePackage::verify`], which decodes them).
    pub fn check_frame(&self, camera: usize, t: u32) -> SceneResult<()> {
        if self.video.is_some() {
            return self.check_indices(camera, t);
        }
        let path = self.frame_path(camera, t)?;
        let name = path.display().to_string();
        let reader = image::ImageReader::open(&path)
            .map_err(|e| SceneError::io(&path, e))?
            .with_guessed_format()
            .map_err(|e| SceneError::io(&path, e))?;
        let (w, h) = reader.into_dimensions().map_err(|source| SceneError::Image { file: name.clone(), source })?;
        let entry = &self.manifest.cameras[camera];
        if (w, h) != (entry.width, entry.height) {
            return Err(SceneError::invalid(
                name,
                "(image size)",
                format!("{w}x{h}, but scene.json says {}x{} for camera {}", entry.width, entry.height, entry.name),
            ));
        }
        Ok(())
    }

    /// Sum of the sizes of every file of the package, in bytes.
    pub fn size_on_disk(&self) -> SceneResult<u64> {
        dir_size(&self.root)
    }
}

fn dir_size(path: &Path) -> SceneResult<u64> {
    let mut total = 0;
    for entry in fs::read_dir(path).map_err(|e| SceneError::io(path, e))? {
        let entry = entry.map_err(|e| SceneError::io(path, e))?;
        let meta = entry.metadata().map_err(|e| SceneError::io(&entry.path(), e))?;
        total += if meta.is_dir() { dir_size(&entry.path())? } else { meta.len() };
    }
    Ok(total)
}

/// Writes a scene package: frames (any order, from any thread), then clouds in time order,
/// then [`SceneWriter::finish`] validates completeness and moves the package into place.
#[derive(Debug)]
pub struct SceneWriter {
    staged: StagedDir,
    staging_dir: PathBuf,
    manifest: Manifest,
    clouds_file: File,
    clouds_bounds: ([f32; 3], [f32; 3]),
    written_steps: Vec<(u32, u32)>,
    /// The cameras' video encoders (video packages only).
    video: Option<VideoWriter>,
}

impl SceneWriter {
    /// Starts a package at `out_dir` (which must not exist, be empty, or be a scene package,
    /// which is replaced only when the new one is complete). `manifest.clouds.byte_length` is
    /// filled in by `finish`; clouds are quantised in `manifest.bounds`. A video package
    /// (`frame_format` vp9) is encoded with the default [`VideoSettings`] at its manifest's
    /// keyframe interval.
    pub fn create(out_dir: impl AsRef<Path>, manifest: Manifest) -> SceneResult<Self> {
        let interval = manifest.frames_index.as_ref().map_or(DEFAULT_KEYFRAME_INTERVAL, |i| i.keyframe_interval);
        Self::create_with(out_dir, manifest, VideoSettings { keyframe_interval: interval, ..VideoSettings::default() })
    }

    /// [`SceneWriter::create`] with the given video settings (used by video packages only;
    /// their keyframe interval is written to the manifest).
    pub fn create_with(out_dir: impl AsRef<Path>, mut manifest: Manifest, video: VideoSettings) -> SceneResult<Self> {
        if let Some(index) = manifest.frames_index.as_mut() {
            index.keyframe_interval = video.keyframe_interval;
            index.byte_length = 0;
        }
        let mut check = manifest.clone();
        check.clouds.byte_length = 0;
        check.validate(MANIFEST_FILE)?;
        let staged = StagedDir::new(out_dir.as_ref(), MANIFEST_FILE, "a dynview scene package")?;
        let staging_dir = staged.path().to_path_buf();
        let frames_dir = staging_dir.join(FRAMES_DIR);
        fs::create_dir_all(&frames_dir).map_err(|e| SceneError::io(&frames_dir, e))?;
        let video = if manifest.frame_format.is_video() {
            Some(VideoWriter::start(&staging_dir, &manifest, video)?)
        } else {
            for camera in &manifest.cameras {
                let dir = frames_dir.join(&camera.name);
                fs::create_dir_all(&dir).map_err(|e| SceneError::io(&dir, e))?;
            }
            None
        };
        let clouds_path = staging_dir.join(&manifest.clouds.file);
        let mut clouds_file = File::create(&clouds_path).map_err(|e| SceneError::io(&clouds_path, e))?;
        // Reserve the index; it is written once all blocks are known.
        let index_len = cloud::index_byte_length(manifest.time_step_count);
        clouds_file.write_all(&vec![0u8; index_len as usize]).map_err(|e| SceneError::io(&clouds_path, e))?;
        let b = manifest.bounds;
        let clouds_bounds = (b.min.map(|v| v as f32), b.max.map(|v| v as f32));
        Ok(Self { staged, staging_dir, manifest, clouds_file, clouds_bounds, written_steps: Vec::new(), video })
    }

    /// The manifest being written.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// Encodes and writes the frame of `camera` at time step `t` (in a video package, each
    /// camera's frames in time order).
    pub fn write_frame(&self, camera: usize, t: u32, image: &image::RgbImage) -> SceneResult<()> {
        let rel = self.checked_frame_path(camera, t)?;
        let entry = &self.manifest.cameras[camera];
        if image.dimensions() != (entry.width, entry.height) {
            return Err(SceneError::invalid(
                rel,
                "(image size)",
                format!("{:?}, expected {}x{}", image.dimensions(), entry.width, entry.height),
            ));
        }
        if let Some(video) = &self.video {
            return video.push(camera, t, image, &rel);
        }
        let bytes = encode_frame(image, self.manifest.frame_format, &rel)?;
        let path = self.staging_dir.join(&rel);
        fs::write(&path, bytes).map_err(|e| SceneError::io(&path, e))
    }

    /// Writes an already encoded frame of `camera` at time step `t` as is, after checking
    /// from its header that it is an image of the package's format and size. A video package
    /// takes an image of any format and encodes it into the camera's video.
    pub fn write_encoded_frame(&self, camera: usize, t: u32, bytes: &[u8]) -> SceneResult<()> {
        let rel = self.checked_frame_path(camera, t)?;
        let entry = &self.manifest.cameras[camera];
        if self.video.is_some() {
            let reader = image::ImageReader::new(std::io::Cursor::new(bytes))
                .with_guessed_format()
                .map_err(|e| SceneError::invalid(&rel, "(image)", e.to_string()))?;
            let image = reader.decode().map_err(|source| SceneError::Image { file: rel.clone(), source })?.to_rgb8();
            return self.write_frame(camera, t, &image);
        }
        let format = super::frame::image_format(self.manifest.frame_format, &rel)?;
        let reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
        let size = reader.into_dimensions().map_err(|source| SceneError::Image { file: rel.clone(), source })?;
        if size != (entry.width, entry.height) {
            return Err(SceneError::invalid(rel, "(image size)", format!("{size:?}, expected {}x{}", entry.width, entry.height)));
        }
        let path = self.staging_dir.join(&rel);
        fs::write(&path, bytes).map_err(|e| SceneError::io(&path, e))
    }

    fn checked_frame_path(&self, camera: usize, t: u32) -> SceneResult<String> {
        if camera >= self.manifest.cameras.len() || t >= self.manifest.time_step_count {
            return Err(SceneError::invalid(MANIFEST_FILE, "cameras", format!("frame ({camera}, {t}) out of range")));
        }
        if self.video.is_some() {
            return Ok(self.manifest.video_relative_path(camera));
        }
        Ok(self.manifest.frame_relative_path(camera, t))
    }

    /// Appends the cloud of the next time step (steps are written in order 0, 1, ...).
    pub fn push_cloud(&mut self, cloud: &PointCloud) -> SceneResult<()> {
        let t = self.written_steps.len();
        if t >= self.manifest.time_step_count as usize {
            return Err(SceneError::invalid("clouds.bin", "step_count", "more clouds than time steps"));
        }
        let (lo, hi) = self.clouds_bounds;
        let block = cloud::encode_step(cloud, lo, hi, t)?;
        let path = self.staging_dir.join(&self.manifest.clouds.file);
        self.clouds_file.write_all(&block).map_err(|e| SceneError::io(&path, e))?;
        self.written_steps.push((cloud.len() as u32, crc32fast::hash(&block)));
        Ok(())
    }

    /// Checks that every cloud and frame was written, writes `scene.json` and moves the
    /// package into place (replacing an older package only now). Returns the manifest.
    pub fn finish(mut self) -> SceneResult<Manifest> {
        let clouds_path = self.staging_dir.join(&self.manifest.clouds.file);
        if self.written_steps.len() != self.manifest.time_step_count as usize {
            return Err(SceneError::invalid(
                "clouds.bin",
                "step_count",
                format!("{} clouds written for {} time steps", self.written_steps.len(), self.manifest.time_step_count),
            ));
        }
        if let Some(video) = self.video.take() {
            let index = video.finish()?;
            for (c, camera) in index.cameras.iter().enumerate() {
                if camera.frames.len() != self.manifest.time_step_count as usize {
                    let rel = self.manifest.video_relative_path(c);
                    return Err(SceneError::invalid(
                        rel,
                        "(video)",
                        format!("{} frames written for {} time steps", camera.frames.len(), self.manifest.time_step_count),
                    ));
                }
            }
            let bytes = index.encode();
            if let Some(entry) = self.manifest.frames_index.as_mut() {
                let path = self.staging_dir.join(&entry.file);
                fs::write(&path, &bytes).map_err(|e| SceneError::io(&path, e))?;
                entry.byte_length = bytes.len() as u64;
            }
        } else {
            for camera in 0..self.manifest.cameras.len() {
                for t in 0..self.manifest.time_step_count {
                    let rel = self.manifest.frame_relative_path(camera, t);
                    if !self.staging_dir.join(&rel).is_file() {
                        return Err(SceneError::invalid(rel, "(file)", "frame was never written"));
                    }
                }
            }
        }
        let (lo, hi) = self.clouds_bounds;
        let index = cloud::encode_index(lo, hi, &self.written_steps);
        let io = |e| SceneError::io(&clouds_path, e);
        self.clouds_file.seek(SeekFrom::Start(0)).map_err(io)?;
        self.clouds_file.write_all(&index).map_err(io)?;
        self.clouds_file.sync_all().map_err(io)?;
        self.manifest.clouds.byte_length = self.clouds_file.metadata().map_err(io)?.len();

        let manifest_path = self.staging_dir.join(MANIFEST_FILE);
        fs::write(&manifest_path, self.manifest.to_json_pretty()).map_err(|e| SceneError::io(&manifest_path, e))?;
        let manifest = self.manifest.clone();
        self.staged.commit()?;
        Ok(manifest)
    }
}

impl ScenePackage {
    /// Full check of the package: decodes every cloud (checksums) and reads the header of every
    /// frame file (existence and size), or decodes every frame of every video.
    /// `progress(done, total)` follows the work.
    pub fn verify(&self, mut progress: impl FnMut(u64, u64)) -> SceneResult<()> {
        let steps = u64::from(self.time_step_count());
        let video_frames = if self.video.is_some() { steps * self.camera_count() as u64 } else { 0 };
        let total = steps + video_frames;
        for t in 0..self.time_step_count() {
            self.read_cloud(t)?;
            for camera in 0..self.camera_count() {
                self.check_frame(camera, t)?;
            }
            progress(u64::from(t) + 1, total);
        }
        if let Some(video) = &self.video {
            video.verify(&self.root, &self.manifest, |done, _| progress(steps + done, total))?;
        }
        Ok(())
    }

    /// The summary printed by `dynview info`.
    pub fn summary(&self) -> SceneResult<super::SceneSummary> {
        Ok(super::SceneSummary::new(&self.manifest, &self.cloud_index, self.size_on_disk()?))
    }
}

impl ScenePackage {
    /// Loads everything the renderer needs for time step `t`: its cloud and every camera's
    /// frame with a `levels`-deep pyramid.
    pub fn time_step_inputs(&self, t: u32, levels: usize) -> SceneResult<crate::render::TimeStepInputs> {
        let cloud = self.read_cloud(t)?;
        let frames = crate::par::map_range(self.camera_count(), |c| self.read_frame(c, t));
        let mut views = Vec::with_capacity(frames.len());
        for (c, frame) in frames.into_iter().enumerate() {
            views.push(crate::render::InputView::new(self.camera(c, t)?, frame?, levels));
        }
        Ok(crate::render::TimeStepInputs { cloud, views })
    }
}
