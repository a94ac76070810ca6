//! What the renderer renders from: the input views of one time step, each with its frame's
//! pyramid, and the time step's sparse cloud. Prepared once per time step, shared by every
//! virtual camera at that time.

use std::sync::{Arc, Mutex, PoisonError};

use super::error::RenderError;
use super::params::RenderParams;
use super::pyramid::{self, camera_at};
use crate::camera::Camera;
use crate::points::PointCloud;
use crate::raster::RgbRaster;

/// An input camera with its frame at every pyramid level (finest first), prepared once per
/// time step and reused for every virtual camera at that time.
#[derive(Clone, Debug)]
pub struct InputView {
    /// The camera at full resolution.
    pub camera: Camera,
    /// The frame at each level, finest first.
    pub levels: Vec<RgbRaster>,
    /// The camera's background plate (the static scene, nothing in front; issue 33) at each
    /// level, finest first, when the camera stands still and the package has one: one pyramid
    /// shared by every time step's inputs ([`PlatePyramids`]).
    pub plate: Option<Arc<Vec<RgbRaster>>>,
}

impl InputView {
    /// Builds the pyramid of `image` (which must match `camera`'s size).
    pub fn new(camera: Camera, image: RgbRaster, levels: usize) -> Self {
        Self { camera, levels: pyramid::build(image, levels.max(1)), plate: None }
    }

    /// The view with its background plate (the size of its frame), as a pyramid of as many
    /// levels as the frame's.
    pub fn with_plate(mut self, plate: RgbRaster) -> Self {
        self.plate = Some(Arc::new(pyramid::build(plate, self.levels.len())));
        self
    }

    /// The view with its background plate's pyramid, built once and shared (the size of its
    /// frame at the finest level; [`TimeStepInputs`]'s check says so where it is not).
    pub fn with_plate_pyramid(mut self, plate: Arc<Vec<RgbRaster>>) -> Self {
        self.plate = Some(plate);
        self
    }

    /// The plate at `level` (the coarsest available when beyond), if the view has one.
    pub(super) fn plate_at(&self, level: usize) -> Option<&RgbRaster> {
        self.plate.as_ref().map(|p| &p[level.min(p.len() - 1)])
    }

    /// The camera and frame at `level` (the coarsest available when beyond).
    pub(super) fn at(&self, level: usize) -> (Camera, &RgbRaster) {
        let image = &self.levels[level.min(self.levels.len() - 1)];
        (camera_at(&self.camera, image.width, image.height), image)
    }
}

/// Everything known about one time step: its sparse cloud and its input views.
#[derive(Clone, Debug)]
pub struct TimeStepInputs {
    /// The sparse cloud of the time step.
    pub cloud: PointCloud,
    /// All input views at this time step (the renderer ranks and picks `params.views`).
    pub views: Vec<InputView>,
    /// How many of the cloud's points, at its end, belong to the static scene (lent by the
    /// package's static cloud); the others are the step's own. 0 when unknown.
    pub static_points: usize,
}

impl TimeStepInputs {
    /// Bytes the decoded inputs hold: the pyramids' f32 RGB pixels and the cloud's points (a
    /// f32 position and an 8-bit color each, 15 bytes). What a cache of time steps counts.
    pub fn decoded_bytes(&self) -> usize {
        let pixels: usize =
            self.views.iter().flat_map(|v| v.levels.iter().chain(v.plate.iter().flat_map(|p| p.iter()))).map(|l| l.data.len()).sum();
        pixels * std::mem::size_of::<[f32; 3]>() + self.cloud.len() * 15
    }
}

/// Checks a render request: valid parameters, at least one view, every frame the size of its
/// camera, an output size in `1..=16384` per side.
pub(super) fn check_inputs(params: &RenderParams, camera: &Camera, inputs: &TimeStepInputs) -> Result<(), RenderError> {
    params.validate()?;
    if inputs.views.is_empty() {
        return Err(RenderError::NoViews);
    }
    for (index, v) in inputs.views.iter().enumerate() {
        let img = &v.levels[0];
        if (img.width, img.height) != (v.camera.width_px as usize, v.camera.height_px as usize) {
            return Err(RenderError::ViewSize {
                index,
                width: img.width,
                height: img.height,
                camera_width: v.camera.width_px,
                camera_height: v.camera.height_px,
            });
        }
        if let Some(plate) = v.plate.as_ref().and_then(|p| p.first())
            && (plate.width, plate.height) != (img.width, img.height)
        {
            return Err(RenderError::PlateSize {
                index,
                width: plate.width,
                height: plate.height,
                frame_width: img.width,
                frame_height: img.height,
            });
        }
    }
    if inputs.static_points > inputs.cloud.len() {
        return Err(RenderError::StaticPoints { static_points: inputs.static_points, points: inputs.cloud.len() });
    }
    let (w, h) = (camera.width_px, camera.height_px);
    if w == 0 || h == 0 || w > 16_384 || h > 16_384 {
        return Err(RenderError::OutputSize { width: w, height: h });
    }
    Ok(())
}

/// Each camera's background plate as a pyramid, built once for a pyramid depth and shared by the
/// inputs of every time step (a plate does not change with time): loading a time step then
/// neither copies the plates nor builds their pyramids again, and the GPU can keep them uploaded.
#[derive(Debug, Default)]
pub struct PlatePyramids {
    built: Mutex<Vec<Option<BuiltPlate>>>,
}

/// A camera's plate pyramid and the depth it was built for.
type BuiltPlate = (usize, Arc<Vec<RgbRaster>>);

impl PlatePyramids {
    /// Camera `camera`'s plate as a pyramid of `levels` levels: built from `plate()` the first
    /// time (or when the depth changed), the same one after; `None` where `plate()` gives none.
    pub fn get_or_build<E>(
        &self,
        camera: usize,
        levels: usize,
        plate: impl FnOnce() -> Result<Option<RgbRaster>, E>,
    ) -> Result<Option<Arc<Vec<RgbRaster>>>, E> {
        let levels = levels.max(1);
        if let Some(Some((built_levels, pyramid))) = self.lock().get(camera)
            && *built_levels == levels
        {
            return Ok(Some(pyramid.clone()));
        }
        let Some(plate) = plate()? else { return Ok(None) };
        let pyramid = Arc::new(pyramid::build(plate, levels));
        let mut built = self.lock();
        if built.len() <= camera {
            built.resize(camera + 1, None);
        }
        built[camera] = Some((levels, pyramid.clone()));
        Ok(Some(pyramid))
    }

    /// Per camera: its pyramid, when built.
    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Option<BuiltPlate>>> {
        self.built.lock().unwrap_or_else(PoisonError::into_inner)
    }
}
