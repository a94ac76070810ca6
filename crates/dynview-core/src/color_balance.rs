//! Color balance between cameras: one affine map per camera and channel that takes its colors
//! to a response shared by all cameras, estimated from the points they see in common.
//!
//! The cameras at an event differ in white balance, exposure and tone (different phones, or
//! one model with automatic settings). Warped into a virtual view, their frames then disagree
//! in color where the geometry is right: the color energy averages them into a cast that no
//! camera had, and its view weights `w_P` read the difference as disagreement. Each point of a
//! time step's cloud that several cameras see unoccluded is a sample of one surface's color in
//! each; the map of a camera is the least-squares affine fit of its samples to their median
//! over the cameras, refitted without the worst residuals (edges, specular highlights, points
//! on the wrong surface).

use crate::camera::Camera;
use crate::points::PointCloud;
use crate::raster::{Rgb, RgbRaster};
use crate::render::sparse::project_cloud;

/// `balanced = gain * color + offset` per channel, colors in `[0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ColorTransform {
    /// Gain per channel (R, G, B).
    pub gain: [f32; 3],
    /// Offset per channel, in `[0, 1]` color units.
    pub offset: [f32; 3],
}

impl Default for ColorTransform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl ColorTransform {
    /// The map that changes nothing.
    pub const IDENTITY: Self = Self { gain: [1.0; 3], offset: [0.0; 3] };

    /// One color mapped (not clamped).
    #[inline]
    pub fn apply(&self, c: Rgb) -> Rgb {
        std::array::from_fn(|k| self.gain[k] * c[k] + self.offset[k])
    }

    /// Every pixel of `image` mapped and clamped to `[0, 1]`.
    pub fn apply_to(&self, image: &mut RgbRaster) {
        if *self == Self::IDENTITY {
            return;
        }
        for px in &mut image.data {
            *px = self.apply(*px).map(|v| v.clamp(0.0, 1.0));
        }
    }

    /// Largest change this map makes to any color in `[0, 1]`.
    pub fn largest_change(&self) -> f32 {
        (0..3).map(|k| self.offset[k].abs().max((self.gain[k] + self.offset[k] - 1.0).abs())).fold(0.0, f32::max)
    }
}

/// Smallest gain a package may store (and an estimate may reach).
pub const MIN_GAIN: f32 = 0.25;
/// Largest gain a package may store (and an estimate may reach).
pub const MAX_GAIN: f32 = 4.0;
/// Largest offset magnitude a package may store.
pub const MAX_OFFSET: f32 = 1.0;

/// One camera at one time step: its camera and its frame.
pub struct CameraFrame<'a> {
    /// The camera.
    pub camera: Camera,
    /// Its frame (the camera's size).
    pub frame: &'a RgbRaster,
}

/// Relative depth within which a point counts as the surface a camera sees at its pixel.
const VISIBLE_DEPTH_RATIO: f32 = 0.01;
/// Relative depth gap of the consistency filter applied to each camera's projected points (the
/// renderer's default `sparse_consistency`): points hidden behind nearer ones are not samples.
const CONSISTENCY_RATIO: f32 = 0.03;
/// Share of the samples with the largest residuals left out of the refit.
const TRIM_SHARE: f64 = 0.2;
/// Fewest samples a camera needs for its own map; below it, the identity.
pub const MIN_SAMPLES: usize = 200;
/// Fits and re-medians.
const ROUNDS: usize = 3;

/// The color samples of one point: `(camera, color)` for each camera that sees it.
pub type PointSamples = Vec<(usize, Rgb)>;

/// Gathers, for every point of `cloud` that at least two of `cameras` (one time step) see
/// unoccluded, its color in each of them (the nearest pixel; the image border left out).
pub fn gather_samples(cloud: &PointCloud, cameras: &[CameraFrame]) -> Vec<PointSamples> {
    let mut per_point: Vec<PointSamples> = vec![Vec::new(); cloud.len()];
    for (c, view) in cameras.iter().enumerate() {
        let (w, h) = (view.camera.width_px as usize, view.camera.height_px as usize);
        // A frame of another size than its camera, or too small to hold an interior pixel,
        // gives no samples.
        if (view.frame.width, view.frame.height) != (w, h) || w < 3 || h < 3 {
            continue;
        }
        let mut maps = project_cloud(cloud, &view.camera);
        maps.drop_inconsistent(CONSISTENCY_RATIO, None, 0);
        for (i, p) in cloud.positions_world.iter().enumerate() {
            let Some((uv, z)) = view.camera.project_world(glam::DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))) else {
                continue;
            };
            let (x, y) = (uv.x.round(), uv.y.round());
            if !(x >= 1.0 && y >= 1.0 && x < (w - 1) as f64 && y < (h - 1) as f64) {
                continue;
            }
            let j = y as usize * w + x as usize;
            let seen = maps.depth.data[j];
            if maps.mask.data[j] > 0.0 && (z as f32) <= seen * (1.0 + VISIBLE_DEPTH_RATIO) {
                per_point[i].push((c, view.frame.data[j]));
            }
        }
    }
    per_point.into_iter().filter(|s| s.len() >= 2).collect()
}

/// The maps of `cameras` cameras from the samples of [`gather_samples`], and each camera's
/// number of samples. A camera with fewer than [`MIN_SAMPLES`] samples keeps the identity and
/// takes no part in the fit. The other maps are normalised so that their mean gain is 1 and
/// mean offset 0 per channel (the shared response is their cameras' average).
pub fn estimate(samples: &[PointSamples], cameras: usize) -> (Vec<ColorTransform>, Vec<usize>) {
    let mut counts = vec![0; cameras];
    for point in samples {
        for &(c, _) in point {
            if let Some(n) = counts.get_mut(c) {
                *n += 1;
            }
        }
    }
    let fitted: Vec<bool> = counts.iter().map(|&n| n >= MIN_SAMPLES).collect();
    let mut maps = vec![ColorTransform::IDENTITY; cameras];
    for _ in 0..ROUNDS {
        // Per camera and channel: (camera color, reference color) pairs.
        let mut pairs: Vec<[Vec<(f64, f64)>; 3]> = (0..cameras).map(|_| Default::default()).collect();
        for point in samples {
            let balanced: Vec<Rgb> =
                point.iter().map(|&(c, color)| maps.get(c).unwrap_or(&ColorTransform::IDENTITY).apply(color)).collect();
            for k in 0..3 {
                let reference = median(balanced.iter().map(|b| f64::from(b[k])).collect());
                for &(c, color) in point.iter().filter(|(c, _)| fitted.get(*c) == Some(&true)) {
                    pairs[c][k].push((f64::from(color[k]), reference));
                }
            }
        }
        for (c, per_channel) in pairs.iter().enumerate().filter(|(c, _)| fitted[*c]) {
            for (k, channel) in per_channel.iter().enumerate() {
                if let Some((gain, offset)) = trimmed_fit(channel) {
                    maps[c].gain[k] = gain as f32;
                    maps[c].offset[k] = offset as f32;
                }
            }
        }
        normalise(&mut maps, &fitted);
    }
    (maps, counts)
}

/// Composes every fitted map with the one affine map that brings their mean gain to 1 and
/// mean offset to 0 (the others stay the identity).
fn normalise(maps: &mut [ColorTransform], fitted: &[bool]) {
    let n = fitted.iter().filter(|&&f| f).count().max(1) as f32;
    for k in 0..3 {
        let chosen = || maps.iter().zip(fitted).filter(|(_, f)| **f).map(|(m, _)| m);
        let mean_gain = chosen().map(|m| m.gain[k]).sum::<f32>() / n;
        let mean_offset = chosen().map(|m| m.offset[k]).sum::<f32>() / n;
        if !(mean_gain.is_finite() && mean_gain > 0.0) {
            continue;
        }
        for m in maps.iter_mut().zip(fitted).filter(|(_, f)| **f).map(|(m, _)| m) {
            m.gain[k] /= mean_gain;
            m.offset[k] = (m.offset[k] - mean_offset) / mean_gain;
        }
    }
}

/// Least-squares `y = g x + o`, then again without the [`TRIM_SHARE`] largest residuals.
/// `None` when the colors do not vary or the gain comes out outside `[0.25, 4]`.
fn trimmed_fit(pairs: &[(f64, f64)]) -> Option<(f64, f64)> {
    let (g, o) = fit(pairs.iter())?;
    let residual = |&(x, y): &(f64, f64)| (y - g * x - o).abs();
    let mut residuals: Vec<f64> = pairs.iter().map(residual).collect();
    let cut = (((1.0 - TRIM_SHARE) * residuals.len() as f64) as usize).min(residuals.len() - 1);
    let (_, &mut keep_below, _) = residuals.select_nth_unstable_by(cut, f64::total_cmp);
    let (g, o) = fit(pairs.iter().filter(|p| residual(p) <= keep_below))?;
    (f64::from(MIN_GAIN)..=f64::from(MAX_GAIN)).contains(&g).then_some((g, o))
}

fn fit<'a>(pairs: impl Iterator<Item = &'a (f64, f64)>) -> Option<(f64, f64)> {
    let (mut n, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(x, y) in pairs {
        n += 1.0;
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
    }
    let var = sxx - sx * sx / n;
    if !(n >= 2.0 && var > 1e-9 * n) {
        return None;
    }
    let g = (sxy - sx * sy / n) / var;
    Some((g, (sy - g * sx) / n))
}

fn median(mut v: Vec<f64>) -> f64 {
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    let upper = *m;
    if v.len() % 2 == 1 {
        upper
    } else {
        let lower = v[..mid].iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lower + upper)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Intrinsics, Rigid3};
    use glam::{DVec2, DVec3};

    const W: u32 = 64;
    const H: u32 = 48;

    /// The color of the ground plane z = 0 at (x, y): smooth, every channel varying.
    fn texture(x: f64, y: f64) -> Rgb {
        [0.5 + 0.3 * (3.0 * x).sin(), 0.5 + 0.3 * (2.0 * y + 1.0).cos(), 0.5 + 0.25 * (2.0 * x - 3.0 * y).sin()].map(|v| v as f32)
    }

    fn camera(x: f64) -> Camera {
        Camera {
            intrinsics: Intrinsics::from_vertical_fov(0.9, W, H),
            camera_from_world: Rigid3::camera_from_world_looking_at(DVec3::new(x, -0.5, 3.0), DVec3::ZERO, DVec3::Y),
            width_px: W,
            height_px: H,
        }
    }

    /// What `camera` films of the plane through its own response `raw = gain * true + offset`.
    fn film(camera: &Camera, response: &ColorTransform) -> RgbRaster {
        let mut data = Vec::new();
        for v in 0..H {
            for u in 0..W {
                let pixel = DVec2::new(f64::from(u), f64::from(v));
                let (a, b) = (camera.unproject_world(pixel, 1.0), camera.unproject_world(pixel, 2.0));
                let p = a + (b - a) * (a.z / (a.z - b.z));
                data.push(response.apply(texture(p.x, p.y)));
            }
        }
        RgbRaster::from_vec(W as usize, H as usize, data).unwrap()
    }

    /// Points on the plane in a grid.
    fn cloud() -> PointCloud {
        let mut cloud = PointCloud::default();
        for i in 0..60 {
            for j in 0..60 {
                let (x, y) = (-1.5 + 3.0 * f64::from(i) / 59.0, -1.2 + 2.4 * f64::from(j) / 59.0);
                cloud.positions_world.push([x as f32, y as f32, 0.0]);
                cloud.colors.push(texture(x, y).map(|v| (v * 255.0) as u8));
            }
        }
        cloud
    }

    fn estimate_for(responses: &[ColorTransform]) -> (Vec<ColorTransform>, Vec<usize>) {
        let cameras: Vec<Camera> = (0..responses.len()).map(|c| camera(-0.6 + 0.4 * c as f64)).collect();
        let frames: Vec<RgbRaster> = cameras.iter().zip(responses).map(|(cam, r)| film(cam, r)).collect();
        let cloud = cloud();
        let views: Vec<CameraFrame> = cameras.iter().zip(&frames).map(|(camera, frame)| CameraFrame { camera: *camera, frame }).collect();
        estimate(&gather_samples(&cloud, &views), responses.len())
    }

    #[test]
    fn cameras_with_different_responses_are_mapped_to_one() {
        let responses = [
            ColorTransform::IDENTITY,
            ColorTransform { gain: [0.8, 0.9, 1.1], offset: [0.1, 0.02, -0.05] },
            ColorTransform { gain: [1.15, 1.0, 0.85], offset: [-0.06, 0.04, 0.08] },
            ColorTransform { gain: [0.95, 1.1, 1.0], offset: [0.0, -0.05, 0.03] },
        ];
        let (maps, counts) = estimate_for(&responses);
        assert!(counts.iter().all(|&n| n >= MIN_SAMPLES), "samples per camera: {counts:?}");
        // A surface color seen by any two cameras comes out the same after their maps.
        for x in [0.25f32, 0.5, 0.75] {
            let balanced: Vec<Rgb> = maps.iter().zip(&responses).map(|(m, r)| m.apply(r.apply([x; 3]))).collect();
            for b in &balanced[1..] {
                for k in 0..3 {
                    assert!((b[k] - balanced[0][k]).abs() < 0.01, "color {x}: {balanced:?}");
                }
            }
        }
        for k in 0..3 {
            let mean_gain = maps.iter().map(|m| m.gain[k]).sum::<f32>() / maps.len() as f32;
            assert!((mean_gain - 1.0).abs() < 1e-4, "mean gain {mean_gain}");
        }
    }

    #[test]
    fn cameras_that_agree_are_left_almost_as_they_are() {
        let (maps, _) = estimate_for(&[ColorTransform::IDENTITY; 3]);
        for m in &maps {
            assert!(m.largest_change() < 1.0 / 255.0, "{m:?}");
        }
    }

    #[test]
    fn a_camera_without_shared_points_keeps_its_colors() {
        let responses = [ColorTransform::IDENTITY, ColorTransform { gain: [0.8; 3], offset: [0.1; 3] }, ColorTransform::IDENTITY];
        let cameras: Vec<Camera> = (0..3).map(|c| camera(-0.4 + 0.4 * c as f64)).collect();
        let mut frames: Vec<RgbRaster> = cameras.iter().zip(&responses).map(|(cam, r)| film(cam, r)).collect();
        // The third camera looks away: a frame of another size than its camera is skipped.
        frames[2] = RgbRaster::filled(8, 8, [0.5; 3]);
        let cloud = cloud();
        let views: Vec<CameraFrame> = cameras.iter().zip(&frames).map(|(camera, frame)| CameraFrame { camera: *camera, frame }).collect();
        let (maps, counts) = estimate(&gather_samples(&cloud, &views), 3);
        assert_eq!(counts[2], 0);
        assert_eq!(maps[2], ColorTransform::IDENTITY);
        let a = maps[0].apply([0.4; 3]);
        let b = maps[1].apply(responses[1].apply([0.4; 3]));
        assert!((0..3).all(|k| (a[k] - b[k]).abs() < 0.01), "{a:?} {b:?}");
    }

    #[test]
    fn the_map_clamps_applied_frames_and_leaves_identity_alone() {
        let mut image = RgbRaster::filled(2, 1, [0.9, 0.1, 0.5]);
        ColorTransform { gain: [1.5; 3], offset: [-0.2; 3] }.apply_to(&mut image);
        assert_eq!(image.data[0], [1.0, 0.0, 0.55]);
        let mut same = RgbRaster::filled(2, 1, [0.3; 3]);
        ColorTransform::IDENTITY.apply_to(&mut same);
        assert_eq!(same.data[0], [0.3; 3]);
    }
}
