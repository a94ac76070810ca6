//! Writing scene packages on a file system.
//!
//! The writer builds the package in a hidden sibling folder ([`StagedDir`]) and renames it into place only
//! when complete, so a failed or interrupted write never leaves a half package and never
//! destroys what was there before.

use std::fs::{self, File};
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::cloud::{CLOUDS_VERSION, CLOUDS_VERSION_CODED, index_byte_length};
use super::cloud_coding::encode_block;
use super::cloud_encode::{encode_coded_index, encode_index, encode_step};
use super::cloud_grid::Grid;
use super::error::{SceneError, SceneResult};
use super::ffmpeg::{DEFAULT_KEYFRAME_INTERVAL, VideoSettings};
use super::frame::encode_frame;
use super::limits::MAX_POINTS_PER_STEP;
use super::manifest::{FORMAT_VERSION_V1, FRAMES_DIR, MANIFEST_FILE, Manifest};
use super::video_files::VideoWriter;
use crate::fsutil::StagedDir;
use crate::points::PointCloud;

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
        // `clouds.bin` version 2 (coded, with a static cloud) in a format v2 package, else 1.
        let clouds_version = if manifest.version == FORMAT_VERSION_V1 { CLOUDS_VERSION } else { CLOUDS_VERSION_CODED };
        let index_len = index_byte_length(clouds_version, manifest.time_step_count);
        clouds_file.write_all(&vec![0u8; index_len as usize]).map_err(|e| SceneError::io(&clouds_path, e))?;
        let b = manifest.bounds;
        let grid = Grid::full(b.min.map(|v| v as f32), b.max.map(|v| v as f32));
        Ok(Self { staged, staging_dir, manifest, clouds_file, grid, static_block: None, written_steps: Vec::new(), video })
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

    /// Writes `camera`'s background plate (`plates/<camera>.jpg`, the camera's frame size) and
    /// marks it in the manifest.
    pub fn write_plate(&mut self, camera: usize, plate: &image::RgbImage) -> SceneResult<()> {
        let Some(entry) = self.manifest.cameras.get(camera) else {
            return Err(SceneError::invalid("scene.json", "cameras", format!("no camera {camera} for a plate")));
        };
        let rel = self.manifest.plate_relative_path(camera);
        if plate.dimensions() != (entry.width, entry.height) {
            return Err(SceneError::invalid(
                rel,
                "(image size)",
                format!("{:?}, expected {}x{}", plate.dimensions(), entry.width, entry.height),
            ));
        }
        let bytes = encode_frame(plate, super::manifest::FrameFormat::Jpeg, &rel)?;
        let dir = self.staging_dir.join(super::manifest::PLATES_DIR);
        fs::create_dir_all(&dir).map_err(|e| SceneError::io(&dir, e))?;
        let path = self.staging_dir.join(&rel);
        fs::write(&path, bytes).map_err(|e| SceneError::io(&path, e))?;
        self.manifest.cameras[camera].plate = true;
        Ok(())
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
        self.manifest.version != FORMAT_VERSION_V1
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
            let block = encode_step(own, lo, hi, t)?;
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
            encode_coded_index(&self.grid, statics, &self.written_steps)
        } else {
            let plain: Vec<(u32, u32)> = self.written_steps.iter().map(|&(_, points, _, crc)| (points, crc)).collect();
            encode_index(lo, hi, &plain)
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
