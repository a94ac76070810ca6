//! Per-timestep points (METHOD.md Part 1 step 3): with the poses fixed, the frames of one time
//! step are matched across cameras only (never through time, which is what lets moving objects
//! be reconstructed), guided by the known epipolar geometry ([`crate::features::guided`]),
//! joined into multi-view tracks, triangulated, filtered by reprojection error, ray angle and
//! cheirality, and colored from the views that see them.

use nalgebra::{Matrix3, Vector2, Vector3};
use opencv::core::Mat;
use opencv::prelude::*;
use rayon::prelude::*;

use dynview_camera::{Radial, Rigid3};

use crate::error::{SfmError, SfmResult};
use crate::estimators::geometry::{Ray, essential_between, triangulate_robust};
use crate::features::guided::guided_matches;
use crate::features::sift::{FeatureOptions, Features, extract_gray};
use crate::features::tracks::Tracks;

/// How the points of a time step are made.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PointOptions {
    /// Lowe's ratio for the cross-camera matches.
    pub ratio: f32,
    /// Largest distance (px) of a match from its epipolar line under the known poses.
    pub max_epipolar_px: f64,
    /// Largest reprojection error (px) of an observation of a point.
    pub max_reprojection_px: f64,
    /// Smallest angle (degrees) between two rays of a point.
    pub min_triangulation_angle_deg: f64,
}

impl Default for PointOptions {
    fn default() -> Self {
        Self { ratio: 0.8, max_epipolar_px: 2.0, max_reprojection_px: 2.0, min_triangulation_angle_deg: 2.0 }
    }
}

/// One camera's frame at the time step, with its calibration.
pub struct TimestepView<'a> {
    /// Intrinsics (the frame is undistorted: `k1`, `k2` apply as given).
    pub intrinsics: Radial,
    /// Pose at this time step, `camera_from_world`.
    pub pose: Rigid3,
    /// The frame, 8-bit BGR.
    pub image_bgr: &'a Mat,
}

/// The points of one time step.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TimestepCloud {
    /// Positions in the world.
    pub positions_world: Vec<Vector3<f64>>,
    /// sRGB colors, the mean over the views that see each point.
    pub colors: Vec<[u8; 3]>,
    /// Number of views of each point.
    pub views: Vec<u8>,
}

/// Symmetric epipolar distance (px at the two focal lengths) of a normalized match.
fn epipolar_distance_px(e: &Matrix3<f64>, na: Vector2<f64>, nb: Vector2<f64>, focal_a: f64, focal_b: f64) -> f64 {
    let (xa, xb) = (Vector3::new(na.x, na.y, 1.0), Vector3::new(nb.x, nb.y, 1.0));
    let (line_b, line_a) = (e * xa, e.transpose() * xb);
    let residual = xb.dot(&line_b).abs();
    let db = residual / line_b.fixed_rows::<2>(0).norm().max(1e-300) * focal_b;
    let da = residual / line_a.fixed_rows::<2>(0).norm().max(1e-300) * focal_a;
    da.max(db)
}

fn color_at(image: &Mat, pixel: Vector2<f64>) -> Option<[f64; 3]> {
    let (x, y) = (pixel.x.round() as i32, pixel.y.round() as i32);
    if x < 0 || y < 0 || x >= image.cols() || y >= image.rows() {
        return None;
    }
    let bgr = image.at_2d::<opencv::core::Vec3b>(y, x).ok()?;
    Some([f64::from(bgr[2]), f64::from(bgr[1]), f64::from(bgr[0])])
}

/// One point of a time step and the pixels that saw it: `(view, pixel)`.
pub type StepTrack = (Vector3<f64>, Vec<(usize, Vector2<f64>)>);

/// One point of a time step and the features that saw it: `(view, feature of that view)`.
pub type FeatureTrack = (Vector3<f64>, Vec<(usize, u32)>);

/// The SIFT features of every view of a time step.
pub fn view_features(views: &[TimestepView], features: &FeatureOptions) -> SfmResult<Vec<Features>> {
    views
        .par_iter()
        .map(|v| {
            let mut gray = Mat::default();
            opencv::imgproc::cvt_color(v.image_bgr, &mut gray, opencv::imgproc::COLOR_BGR2GRAY, 0).map_err(SfmError::cv("grayscale"))?;
            extract_gray(&gray, features)
        })
        .collect()
}

/// Matches the views of one time step across cameras only (guided by their poses) and
/// triangulates the tracks; each point comes with the observations kept.
pub fn timestep_tracks(views: &[TimestepView], features: &FeatureOptions, options: &PointOptions) -> SfmResult<Vec<StepTrack>> {
    let extracted = view_features(views, features)?;
    Ok(feature_tracks(views, &extracted, options)
        .into_iter()
        .map(|(xyz, seen)| (xyz, seen.into_iter().map(|(v, f)| (v, pixel_of(&extracted[v], f))).collect()))
        .collect())
}

fn pixel_of(features: &Features, feature: u32) -> Vector2<f64> {
    let xy = features.xy[feature as usize];
    Vector2::new(f64::from(xy[0]), f64::from(xy[1]))
}

/// [`timestep_tracks`] over features already extracted (`extracted[v]` is view `v`'s), each
/// point with the features that saw it.
pub fn feature_tracks(views: &[TimestepView], extracted: &[Features], options: &PointOptions) -> Vec<FeatureTrack> {
    let pixel = |v: usize, f: u32| pixel_of(&extracted[v], f);
    let mut pairs = Vec::new();
    for a in 0..views.len() {
        for b in a + 1..views.len() {
            let e = essential_between(&views[a].pose, &views[b].pose);
            let (ka, kb) = (&views[a].intrinsics, &views[b].intrinsics);
            let matches: Vec<[u32; 2]> =
                guided_matches((&extracted[a], ka), (&extracted[b], kb), &e, options.max_epipolar_px, options.ratio)
                    .into_iter()
                    .filter(|m| {
                        let (na, nb) = (ka.normalized(pixel(a, m[0])), kb.normalized(pixel(b, m[1])));
                        epipolar_distance_px(&e, na, nb, ka.f, kb.f) <= options.max_epipolar_px
                    })
                    .collect();
            pairs.push((a, b, matches));
        }
    }
    let counts: Vec<usize> = extracted.iter().map(Features::len).collect();
    let tracks = Tracks::build(&counts, &pairs);
    tracks
        .tracks
        .iter()
        .filter_map(|track| {
            let rays: Vec<Ray> = track.iter().map(|&(v, f)| (views[v].intrinsics, views[v].pose, pixel(v, f))).collect();
            let (xyz, kept) = triangulate_robust(&rays, options.max_reprojection_px, options.min_triangulation_angle_deg)?;
            Some((xyz, kept.iter().map(|&k| track[k]).collect()))
        })
        .collect()
}

/// Triangulates the points of one time step from its views, coloured by the mean of the pixels
/// that saw them.
pub fn timestep_points(views: &[TimestepView], features: &FeatureOptions, options: &PointOptions) -> SfmResult<TimestepCloud> {
    let mut cloud = TimestepCloud::default();
    for (xyz, observations) in timestep_tracks(views, features, options)? {
        let samples: Vec<[f64; 3]> = observations.iter().filter_map(|&(v, pixel)| color_at(views[v].image_bgr, pixel)).collect();
        if samples.is_empty() {
            continue;
        }
        let mean = |c: usize| (samples.iter().map(|s| s[c]).sum::<f64>() / samples.len() as f64).round().clamp(0.0, 255.0) as u8;
        cloud.positions_world.push(xyz);
        cloud.colors.push([mean(0), mean(1), mean(2)]);
        cloud.views.push(observations.len().min(255) as u8);
    }
    Ok(cloud)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_essential_matrix_of_two_poses_holds_for_their_points() {
        let a = Rigid3::from_angle_axis_center(Vector3::new(0.0, 0.2, 0.0), Vector3::new(-1.0, 0.0, 0.0));
        let b = Rigid3::from_angle_axis_center(Vector3::new(0.05, -0.2, 0.0), Vector3::new(1.0, 0.2, 0.1));
        let e = essential_between(&a, &b);
        for p in [Vector3::new(0.3, 0.1, 5.0), Vector3::new(-0.5, 0.4, 7.0)] {
            let (na, nb) = (a.project_normalized(&p).unwrap(), b.project_normalized(&p).unwrap());
            assert!(epipolar_distance_px(&e, na, nb, 500.0, 500.0) < 1e-9);
            assert!(epipolar_distance_px(&e, na, nb + Vector2::new(0.0, 0.01), 500.0, 500.0) > 1.0);
        }
    }
}
