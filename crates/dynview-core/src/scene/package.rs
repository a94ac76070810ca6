//! Reading scene packages on a file system (the writer is [`super::writer::SceneWriter`]).

use std::fs::{self, File};
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use super::cloud::{self, CloudIndex};
use super::error::{SceneError, SceneResult};
use super::limits::{MAX_FRAME_FILE_BYTES, MAX_MANIFEST_BYTES};
use super::manifest::{FrameFormat, MANIFEST_FILE, Manifest};
use super::video::FrameIndex;
use super::video_files::VideoFrames;
use crate::camera::Camera;
use crate::points::PointCloud;
use crate::raster::RgbRaster;

pub use super::frame::{JPEG_QUALITY, decode_frame, encode_frame};
pub use super::writer::SceneWriter;

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
    /// The cameras' background plates, color-balanced, read at the first step that needs them.
    plates: Mutex<Vec<Option<Arc<RgbRaster>>>>,
    /// The plates as pyramids, shared by every time step's inputs.
    plate_pyramids: crate::render::PlatePyramids,
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
        Ok(Self {
            root,
            manifest,
            cloud_index,
            video,
            statics: Mutex::new(None),
            plates: Mutex::new(Vec::new()),
            plate_pyramids: Default::default(),
        })
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
        let (name, entry) = self.step_entry(t)?;
        let block = self.read_block(&entry, &format!("steps[{t}]"))?;
        self.cloud_index.decode_step(t as usize, &block, Some(self.static_cloud()?.as_ref()), &name)
    }

    /// The cloud of time step `t` as stored: its own points and the indices of the static
    /// points ([`ScenePackage::static_cloud`]) it borrows.
    pub fn read_cloud_parts(&self, t: u32) -> SceneResult<(PointCloud, Vec<u32>)> {
        let (name, entry) = self.step_entry(t)?;
        let block = self.read_block(&entry, &format!("steps[{t}]"))?;
        let static_count = self.static_cloud()?.len() as u32;
        self.cloud_index.decode_step_parts(t as usize, &block, static_count, &name)
    }

    /// The clouds file's name (for errors) and step `t`'s table entry.
    fn step_entry(&self, t: u32) -> SceneResult<(String, cloud::StepEntry)> {
        let name = self.root.join(&self.manifest.clouds.file).display().to_string();
        match self.cloud_index.steps.get(t as usize).copied() {
            Some(entry) => Ok((name, entry)),
            None => Err(SceneError::invalid(&name, "steps", format!("time step {t} out of range"))),
        }
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

impl ScenePackage {
    /// Full check of the package: decodes every plate and every cloud (checksums) and reads the
    /// header of every frame file (existence and size), or decodes every frame of every video.
    /// `progress(done, total)` follows the work.
    pub fn verify(&self, mut progress: impl FnMut(u64, u64)) -> SceneResult<()> {
        for camera in 0..self.camera_count() {
            self.stored_plate(camera)?;
        }
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
    /// frame, its color balance applied ([`Manifest::input_view`]), with a `levels`-deep
    /// pyramid.
    pub fn time_step_inputs(&self, t: u32, levels: usize) -> SceneResult<crate::render::TimeStepInputs> {
        let cloud = self.read_cloud(t)?;
        let static_points = self.step_entry(t)?.1.borrowed_count as usize;
        let frames = crate::par::map_range(self.camera_count(), |c| self.read_frame(c, t));
        let mut views = Vec::with_capacity(frames.len());
        for (c, frame) in frames.into_iter().enumerate() {
            let view = self.manifest.input_view(c, t, frame?, levels);
            views.push(
                match self
                    .plate_pyramids
                    .get_or_build(c, levels, || Ok::<_, SceneError>(self.stored_plate(c)?.map(|p| self.manifest.balanced_plate(c, p))))?
                {
                    Some(plate) => view.with_plate_pyramid(plate),
                    None => view,
                },
            );
        }
        Ok(crate::render::TimeStepInputs { cloud, views, static_points })
    }

    /// Camera `camera`'s background plate as stored (`None` when the package has none for it),
    /// its size checked.
    pub fn stored_plate(&self, camera: usize) -> SceneResult<Option<RgbRaster>> {
        let Some(entry) = self.manifest.cameras.get(camera).filter(|e| e.plate) else {
            return Ok(None);
        };
        let path = self.root.join(self.manifest.plate_relative_path(camera));
        let bytes = read_limited(&path, MAX_FRAME_FILE_BYTES)?;
        decode_frame(&bytes, FrameFormat::Jpeg, entry.width, entry.height, &path.display().to_string()).map(Some)
    }

    /// Camera `camera`'s background plate, color-balanced as its frames are (`None` when the
    /// package has none for it), read once.
    pub fn plate(&self, camera: usize) -> SceneResult<Option<Arc<RgbRaster>>> {
        let Some(entry) = self.manifest.cameras.get(camera).filter(|e| e.plate) else {
            return Ok(None);
        };
        let mut cached = self.plates.lock().map_err(|_| SceneError::invalid(&entry.name, "plate", "an earlier read failed"))?;
        if cached.len() != self.manifest.cameras.len() {
            *cached = vec![None; self.manifest.cameras.len()];
        }
        if let Some(plate) = &cached[camera] {
            return Ok(Some(plate.clone()));
        }
        let Some(plate) = self.stored_plate(camera)? else { return Ok(None) };
        let plate = Arc::new(self.manifest.balanced_plate(camera, plate));
        cached[camera] = Some(plate.clone());
        Ok(Some(plate))
    }
}
