//! Reading and writing scene packages on a file system.
//!
//! The writer builds the package in a hidden sibling folder ([`StagedDir`]) and renames it into place only
//! when complete, so a failed or interrupted write never leaves a half package and never
//! destroys what was there before.

use std::fs::{self, File};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use super::cloud::{self, CloudIndex, Grid, PointCloud};
use super::cloud_coding::encode_block;
use super::error::{SceneError, SceneResult};
use super::ffmpeg::{DEFAULT_KEYFRAME_INTERVAL, VideoSettings};
use super::limits::{MAX_FRAME_FILE_BYTES, MAX_MANIFEST_BYTES, MAX_POINTS_PER_STEP};
use super::manifest::{FORMAT_VERSION_V1, FRAMES_DIR, MANIFEST_FILE, Manifest};
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
    /// The static cloud, read at the first step that needs it (version 2 clouds).
    statics: Mutex<Option<Arc<PointCloud>>>,
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
        let (version, step_count) = CloudIndex::peek(&header, &clouds_name)?;
        if step_count != manifest.time_step_count {
            return Err(SceneError::invalid(
                &clouds_name,
                "step_count",
                format!("{step_count} steps but scene.json has time_step_count {}", manifest.time_step_count),
            ));
        }
        let index_len = cloud::index_byte_length(version, step_count);
        if index_len > file_length {
            return Err(SceneError::invalid(&clouds_name, "steps", "file too short for the offset table"));
        }
        let mut index_bytes = header.to_vec();
        index_bytes.resize(index_len as usize, 0);
        file.read_exact(&mut index_bytes[cloud::HEADER_BYTES..]).map_err(|e| SceneError::io(&clouds_path, e))?;
        let cloud_index = CloudIndex::parse(&index_bytes, file_length, &clouds_name)?;
        let video = if manifest.frame_format.is_video() { Some(VideoFrames::open(&root, &manifest)?) } else { None };
        Ok(Self { root, manifest, cloud_index, video, statics: Mutex::new(None) })
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

    fn read_block(&self, entry: &cloud::StepEntry, name: &str) -> SceneResult<Vec<u8>> {
        let path = self.root.join(&self.manifest.clouds.file);
        let mut file = File::open(&path).map_err(|e| SceneError::io(&path, e))?;
        file.seek(SeekFrom::Start(entry.offset)).map_err(|e| SceneError::io(&path, e))?;
        let mut block = vec![0u8; entry.byte_length() as usize];
        file.read_exact(&mut block)
            .map_err(|_| SceneError::invalid(path.display().to_string(), name, "block truncated (file changed since it was opened?)"))?;
        Ok(block)
    }

    /// The static cloud of a version 2 clouds file (empty for version 1), read once.
    pub fn static_cloud(&self) -> SceneResult<Arc<PointCloud>> {
        let Some(entry) = self.cloud_index.static_block else {
            return Ok(Arc::default());
        };
        let mut cached =
            self.statics.lock().map_err(|_| SceneError::invalid(&self.manifest.clouds.file, "static", "an earlier read failed"))?;
        if let Some(statics) = cached.as_ref() {
            return Ok(statics.clone());
        }
        let name = self.root.join(&self.manifest.clouds.file).display().to_string();
        let statics = Arc::new(self.cloud_index.decode_static(&self.read_block(&entry, "static")?, &name)?);
        *cached = Some(statics.clone());
        Ok(statics)
    }

    /// Reads and decodes the cloud of time step `t`, touching no other step's bytes (but the
    /// static cloud's, once, in a version 2 file).
    pub fn read_cloud(&self, t: u32) -> SceneResult<PointCloud> {
        let (mut cloud, borrowed) = self.read_cloud_parts(t)?;
        let statics = self.static_cloud()?;
        cloud.positions_world.extend(borrowed.iter().map(|&i| statics.positions_world[i as usize]));
        cloud.colors.extend(borrowed.iter().map(|&i| statics.colors[i as usize]));
        Ok(cloud)
    }

    /// The cloud of time step `t` as stored: its own points and the indices of the static
    /// points ([`ScenePackage::static_cloud`]) it borrows.
    pub fn read_cloud_parts(&self, t: u32) -> SceneResult<(PointCloud, Vec<u32>)> {
        let name = self.root.join(&self.manifest.clouds.file).display().to_string();
        let Some(entry) = self.cloud_index.steps.get(t as usize).copied() else {
            return Err(SceneError::invalid(&name, "steps", format!("time step {t} out of range")));
        };
        let block = self.read_block(&entry, &format!("steps[{t}]"))?;
        let static_count = self.static_cloud()?.len() as u32;
        self.cloud_index.decode_step_parts(t as usize, &block, static_count, &name)
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
    /// The clouds' quantisation grid (16 bits unless [`SceneWriter::set_position_step`]).
    grid: Grid,
    /// `clouds.bin` version: 2 (coded, with a static cloud) in a format v2 package, else 1.
    clouds_version: u32,
    /// The static block once written (version 2): `(byte_length, point_count, crc32)`.
    static_block: Option<(u32, u32, u32)>,
    /// Per written step: `(byte_length, point_count, borrowed_count, crc32)`.
    written_steps: Vec<(u32, u32, u32, u32)>,
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
        let clouds_version = if manifest.version == FORMAT_VERSION_V1 { cloud::CLOUDS_VERSION } else { cloud::CLOUDS_VERSION_CODED };
        let index_len = cloud::index_byte_length(clouds_version, manifest.time_step_count);
        clouds_file.write_all(&vec![0u8; index_len as usize]).map_err(|e| SceneError::io(&clouds_path, e))?;
        let b = manifest.bounds;
        let grid = Grid::full(b.min.map(|v| v as f32), b.max.map(|v| v as f32));
        Ok(Self { staged, staging_dir, manifest, clouds_file, grid, clouds_version, static_block: None, written_steps: Vec::new(), video })
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

    fn write_block(&mut self, block: &[u8]) -> SceneResult<u32> {
        let path = self.staging_dir.join(&self.manifest.clouds.file);
        self.clouds_file.write_all(block).map_err(|e| SceneError::io(&path, e))?;
        u32::try_from(block.len()).map_err(|_| SceneError::invalid("clouds.bin", "steps", "a block of 4 GiB or more"))
    }

    /// Whether the package stores a static cloud once and lets steps borrow from it (format
    /// v2); a format v1 package stores every step's points in full.
    pub fn has_static_cloud(&self) -> bool {
        self.clouds_version == cloud::CLOUDS_VERSION_CODED
    }

    /// Quantises the clouds of a format v2 package on the coarsest grid whose step is at most
    /// `step` (world units) instead of the 16-bit one: a smaller package where the points are
    /// no more precise than that anyway. Before any cloud is written.
    pub fn set_position_step(&mut self, step: f64) -> SceneResult<()> {
        if !self.has_static_cloud() || self.static_block.is_some() {
            return Err(SceneError::invalid("clouds.bin", "position_bits", "the grid is chosen before any cloud, in a format v2 package"));
        }
        self.grid = Grid { color_bits: self.grid.color_bits, ..Grid::with_step(self.grid.bounds_min, self.grid.bounds_max, step) };
        Ok(())
    }

    /// Stores the clouds' colors on `bits` (4 to 8) per channel instead of 8, in a format v2
    /// package. Before any cloud is written.
    pub fn set_color_bits(&mut self, bits: u32) -> SceneResult<()> {
        if !self.has_static_cloud() || self.static_block.is_some() || !(4..=8).contains(&bits) {
            return Err(SceneError::invalid("clouds.bin", "color_bits", "4 to 8 bits, chosen before any cloud, in a format v2 package"));
        }
        self.grid.color_bits = bits;
        Ok(())
    }

    /// Stores the event's static cloud (format v2, before any step's cloud); steps then borrow
    /// its points by index ([`SceneWriter::push_cloud_borrowing`]).
    pub fn set_static_cloud(&mut self, statics: &PointCloud) -> SceneResult<()> {
        if !self.has_static_cloud() || self.static_block.is_some() || !self.written_steps.is_empty() {
            return Err(SceneError::invalid(
                "clouds.bin",
                "static",
                "a static cloud is stored once, before the steps, in a format v2 package",
            ));
        }
        if statics.len() > MAX_POINTS_PER_STEP as usize {
            return Err(SceneError::invalid(
                "clouds.bin",
                "static.point_count",
                format!("{} exceeds {MAX_POINTS_PER_STEP}", statics.len()),
            ));
        }
        let block = encode_block(statics, &[], &self.grid, "static")?;
        let length = self.write_block(&block)?;
        self.static_block = Some((length, statics.len() as u32, crc32fast::hash(&block)));
        Ok(())
    }

    /// Appends the cloud of the next time step (steps are written in order 0, 1, ...).
    pub fn push_cloud(&mut self, cloud: &PointCloud) -> SceneResult<()> {
        self.push_cloud_borrowing(cloud, &[])
    }

    /// Appends the next time step's cloud: its `own` points and the static points it borrows
    /// (ascending indices into the static cloud; format v2 only).
    pub fn push_cloud_borrowing(&mut self, own: &PointCloud, borrowed: &[u32]) -> SceneResult<()> {
        let t = self.written_steps.len();
        if t >= self.manifest.time_step_count as usize {
            return Err(SceneError::invalid("clouds.bin", "step_count", "more clouds than time steps"));
        }
        let field = format!("steps[{t}]");
        let (lo, hi) = (self.grid.bounds_min, self.grid.bounds_max);
        if !self.has_static_cloud() {
            if !borrowed.is_empty() {
                return Err(SceneError::invalid("clouds.bin", field, "a format v1 package has no static cloud to borrow from"));
            }
            let block = cloud::encode_step(own, lo, hi, t)?;
            self.write_block(&block)?;
            self.written_steps.push((block.len() as u32, own.len() as u32, 0, crc32fast::hash(&block)));
            return Ok(());
        }
        if self.static_block.is_none() {
            self.set_static_cloud(&PointCloud::default())?;
        }
        let static_count = self.static_block.map_or(0, |s| s.1);
        if borrowed.last().is_some_and(|&i| i >= static_count) {
            return Err(SceneError::invalid(
                "clouds.bin",
                format!("{field}.borrowed"),
                format!("an index past the {static_count} static points"),
            ));
        }
        let total = own.len() + borrowed.len();
        if total > MAX_POINTS_PER_STEP as usize {
            return Err(SceneError::invalid(
                "clouds.bin",
                format!("{field}.point_count"),
                format!("{total} exceeds {MAX_POINTS_PER_STEP}"),
            ));
        }
        let block = encode_block(own, borrowed, &self.grid, &field)?;
        let length = self.write_block(&block)?;
        self.written_steps.push((length, total as u32, borrowed.len() as u32, crc32fast::hash(&block)));
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
        let (lo, hi) = (self.grid.bounds_min, self.grid.bounds_max);
        let index = if self.has_static_cloud() {
            let statics = self.static_block.unwrap_or((0, 0, 0));
            cloud::encode_coded_index(&self.grid, statics, &self.written_steps)
        } else {
            let plain: Vec<(u32, u32)> = self.written_steps.iter().map(|&(_, points, _, crc)| (points, crc)).collect();
            cloud::encode_index(lo, hi, &plain)
        };
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
