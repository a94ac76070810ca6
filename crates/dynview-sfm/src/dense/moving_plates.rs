//! Background plates for cameras that move (issue 35, item 1: hand-held cameras).
//!
//! A camera that stands still gets one plate for the whole event ([`super::plates`]). A
//! hand-held camera's view changes from step to step, so each of its steps gets its own: the
//! same camera's frames of a few steps before and after ([`STEP_OFFSETS`]) are carried onto the
//! step's frame through the scene's depth at that step (prep gives the nearest of the static
//! points and the step's own points), each with its own pose, and each pixel's plate colour is the most stable of the colours they bring, found by the
//! plates' colour modes ([`super::plates::pixel_plate`]). What moves has moved on in most of
//! those frames; the static scene lies where its depth puts it, parallax included (a homography
//! between the frames would leave the parallax of a few centimetres of hand shake).
//!
//! Where a pixel has no depth, or fewer than [`MIN_SAMPLES`] of the
//! frames see its point, the pixel's confidence is 0: its foreground is unknown, and it neither
//! starts hull rays nor carves. The step's own frame is not among the samples: its foreground
//! is what differs from the others.

use dynview_core::Camera;
use dynview_core::raster::ScalarRaster;
use glam::{DVec2, DVec3};
use image::RgbImage;
use rayon::prelude::*;

use super::plates::{Plate, PlateMode, PlateOptions, pixel_plate};

/// Steps (before and after the plate's own) whose frames make a moving camera's plate: what
/// moves clears a pixel within a few tenths of a second at 30 steps a second.
pub const STEP_OFFSETS: [i64; 8] = [-12, -9, -6, -3, 3, 6, 9, 12];

/// Fewest frames that must see a pixel's static point for its plate to count.
pub const MIN_SAMPLES: usize = 3;

/// Radius (px) each point covers in the depth map the frames are carried through: the points
/// are sparser than the pixels.
pub const DEPTH_FOOTPRINT_PX: usize = 3;

/// One row of a plate being made: colours, confidences and other modes.
type PlateRow = (Vec<[u8; 3]>, Vec<f32>, Vec<PlateMode>);

/// One of the camera's frames at another step, with the pose it was filmed from.
#[derive(Clone, Copy, Debug)]
pub struct PlateSample<'a> {
    /// The camera at that step (the same working size as the plate's).
    pub camera: &'a Camera,
    /// Its frame at that step.
    pub frame: &'a RgbImage,
}

/// The plate of `target` (the camera at the step) from `samples` (its frames at other steps),
/// carried through `static_depth_m` (z-depth of the static scene in `target`, not finite where
/// unknown). Confidence per pixel: the share of the samples that saw it that agree with its
/// plate colour; 0 where fewer than [`MIN_SAMPLES`] saw it or its depth is unknown.
pub fn moving_plate(target: &Camera, static_depth_m: &ScalarRaster, samples: &[PlateSample], options: &PlateOptions) -> Plate {
    let (w, h) = (target.width_px as usize, target.height_px as usize);
    let world_from_camera = target.camera_from_world.inverse();
    let k = options.modes.max(1);
    let rows: Vec<PlateRow> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut colors = vec![[0u8; 3]; w];
            let mut confidence = vec![0.0f32; w];
            let mut others = vec![PlateMode::default(); w * (k - 1)];
            let mut values = Vec::with_capacity(samples.len());
            for x in 0..w {
                let depth = static_depth_m.data.get(y * w + x).copied().unwrap_or(f32::INFINITY);
                if !(depth.is_finite() && depth > 0.0) {
                    continue;
                }
                let point_camera = target.intrinsics.unproject(DVec2::new(x as f64, y as f64), f64::from(depth));
                let point_world = world_from_camera.transform_point(point_camera);
                values.clear();
                values.extend(samples.iter().filter_map(|s| sample_at(s, point_world)));
                if values.len() < MIN_SAMPLES {
                    continue;
                }
                (colors[x], confidence[x]) = pixel_plate(&values, options, &mut others[x * (k - 1)..(x + 1) * (k - 1)]);
            }
            (colors, confidence, others)
        })
        .collect();
    let mut image = RgbImage::new(w as u32, h as u32);
    let mut confidence = Vec::with_capacity(w * h);
    let mut others = Vec::with_capacity(w * h * (k - 1));
    for (y, (row_colors, row_confidence, row_others)) in rows.into_iter().enumerate() {
        for (x, color) in row_colors.into_iter().enumerate() {
            image.put_pixel(x as u32, y as u32, image::Rgb(color));
        }
        confidence.extend(row_confidence);
        others.extend(row_others);
    }
    Plate { image, confidence, frames: samples.len() as u64, others }
}

/// The colour (8-bit levels) `sample`'s frame shows at `point_world`, bilinear between pixel
/// centres; `None` behind the camera or outside its frame.
fn sample_at(sample: &PlateSample, point_world: DVec3) -> Option<[f32; 3]> {
    let (pixel, z) = sample.camera.project_world(point_world)?;
    let (w, h) = (sample.frame.width(), sample.frame.height());
    if !(z > 0.0 && pixel.x >= 0.0 && pixel.y >= 0.0 && pixel.x <= f64::from(w - 1) && pixel.y <= f64::from(h - 1)) {
        return None;
    }
    let (x0, y0) = (pixel.x.floor() as u32, pixel.y.floor() as u32);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = ((pixel.x - f64::from(x0)) as f32, (pixel.y - f64::from(y0)) as f32);
    let at = |x: u32, y: u32| sample.frame.get_pixel(x, y).0.map(f32::from);
    let (a, b, c, d) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
    Some(std::array::from_fn(|i| (a[i] * (1.0 - fx) + b[i] * fx) * (1.0 - fy) + (c[i] * (1.0 - fx) + d[i] * fx) * fy))
}

/// The median and the 95th percentile of the finite depths of `static_depth_m`; `None` with
/// fewer than 16 of them (the hull's depth range of a camera, [`super::hull::depth_range`], as
/// [`super::hull::static_depths`] gives a still camera's).
pub fn depth_range(static_depth_m: &ScalarRaster) -> Option<(f64, f64)> {
    let mut depths: Vec<f64> = static_depth_m.data.iter().filter(|d| d.is_finite() && **d > 0.0).map(|&d| f64::from(d)).collect();
    super::hull::depth_range(&mut depths)
}

#[cfg(test)]
mod tests;
