//! Plates made per step for the cameras without a plate of their own (the hand-held ones;
//! [`crate::dense::moving_plates`]), from a sliding window of their frames, each read once.

use std::collections::BTreeMap;

use dynview_core::Camera;
use dynview_core::raster::ScalarRaster;
use dynview_core::scene::PointCloud;
use image::RgbImage;

use crate::dense::Plate;
use crate::dense::free_space::static_depth_map;
use crate::dense::moving_plates::{DEPTH_FOOTPRINT_PX, PlateSample, STEP_OFFSETS, depth_range, moving_plate};
use crate::dense::plates::PlateOptions;
use crate::error::SfmResult;

/// A camera's plate at one step and the hull's depth range in it (median and far static
/// depth, m; `None` where the static cloud gives too few depths).
pub(super) type StepPlate = (Plate, Option<(f64, f64)>);

/// The frames of the cameras that get a plate per step, at the steps around the current one.
/// Memory: at most `2 * max |STEP_OFFSETS| + 1` steps of those cameras' working frames.
pub(super) struct StepPlates<'a> {
    /// The cameras (indices into the manifest) that get a plate per step.
    cameras: Vec<usize>,
    /// The static scene their frames are carried through.
    static_points: &'a PointCloud,
    options: PlateOptions,
    /// Steps: the frames of `cameras`, in their order.
    window: BTreeMap<usize, Vec<RgbImage>>,
}

impl<'a> StepPlates<'a> {
    /// Plates per step for `cameras` through `static_points`; colours as `options` compare them.
    pub(super) fn new(cameras: Vec<usize>, static_points: &'a PointCloud, options: PlateOptions) -> Self {
        Self { cameras, static_points, options, window: BTreeMap::new() }
    }

    /// The cameras that get a plate per step.
    pub(super) fn cameras(&self) -> &[usize] {
        &self.cameras
    }

    /// The plate of each of [`Self::cameras`] at step `t` (of `steps`), in their order:
    /// `own` are the step's own points, `frame_at(c, s)` reads camera `c`'s working frame at
    /// step `s`, `camera_at(c, s)` gives the camera then. Steps are asked for in increasing
    /// order; those the window has left are forgotten.
    pub(super) fn at(
        &mut self,
        t: usize,
        steps: usize,
        own: &PointCloud,
        frame_at: impl Fn(usize, usize) -> SfmResult<RgbImage>,
        camera_at: impl Fn(usize, usize) -> Camera,
    ) -> SfmResult<Vec<StepPlate>> {
        let reach = STEP_OFFSETS.iter().map(|o| o.unsigned_abs() as usize).max().unwrap_or(0);
        self.window.retain(|&s, _| s + reach >= t);
        let wanted: Vec<usize> = STEP_OFFSETS.iter().filter_map(|&o| t.checked_add_signed(o as isize)).filter(|&s| s < steps).collect();
        for &s in &wanted {
            if !self.window.contains_key(&s) {
                let frames = self.cameras.iter().map(|&c| frame_at(c, s)).collect::<SfmResult<Vec<_>>>()?;
                self.window.insert(s, frames);
            }
        }
        let mut out = Vec::with_capacity(self.cameras.len());
        for (k, &c) in self.cameras.iter().enumerate() {
            let target = camera_at(c, t);
            let depth = scene_depth(&target, self.static_points, own);
            let cameras: Vec<Camera> = wanted.iter().map(|&s| camera_at(c, s)).collect();
            let samples: Vec<PlateSample> =
                wanted.iter().zip(&cameras).map(|(s, camera)| PlateSample { camera, frame: &self.window[s][k] }).collect();
            let plate = moving_plate(&target, &depth, &samples, &self.options);
            out.push((plate, depth_range(&depth)));
        }
        Ok(out)
    }
}

/// The depth (m) the frames are carried through onto `camera`: the nearest of the static points
/// and the step's `own` points (what moves in the frame is carried to where it stood, which the
/// other frames show empty), each covering [`DEPTH_FOOTPRINT_PX`]; where neither lands, the
/// median of the others (a plane: the camera moves a few centimetres between the frames, so a
/// wrong depth there moves a sample by a few pixels at most, and there are no points where
/// there is no texture to misplace).
fn scene_depth(camera: &Camera, static_points: &PointCloud, own: &PointCloud) -> ScalarRaster {
    let mut depth = static_depth_map(camera, static_points, DEPTH_FOOTPRINT_PX);
    let own_depth = static_depth_map(camera, own, DEPTH_FOOTPRINT_PX);
    depth.data.iter_mut().zip(&own_depth.data).for_each(|(d, o)| *d = d.min(*o));
    if let Some((median, _)) = depth_range(&depth) {
        depth.data.iter_mut().filter(|d| !d.is_finite()).for_each(|d| *d = median as f32);
    }
    depth
}
