//! The depth prior where the points say little: one plane fitted to the step's points as the
//! virtual camera sees them (issue 15, "geometry that degrades gracefully").
//!
//! Between sparse points the depth energy is a membrane: with a few hundred points per step
//! (real footage between wide-baseline cameras) its minimiser is a field of bumps around each
//! point that relaxes to a mean in between, and the views warped with it swirl. A weak pull
//! toward one plane (`RenderParams::lambda_plane`) keeps the points' depth near the points and
//! lets the depth far from them settle on the dominant surface (a floor, a wall). A plane warps
//! a view as a homography, so where it is wrong the picture is displaced, not torn.

use crate::camera::Camera;
use crate::points::PointCloud;
use crate::raster::ScalarRaster;
use glam::{DMat3, DVec3};

/// RANSAC hypotheses of the fit.
const HYPOTHESES: usize = 256;
/// An inverse depth within this share of the median inverse depth fits the plane.
const INLIER_SHARE: f64 = 0.05;
/// At most this many points enter the fit (evenly strided through the cloud).
const MAX_SAMPLES: usize = 4096;
/// Least spread of a plane's inliers over the image, as the standard deviation of their
/// normalised image coordinates along the narrowest direction: 0.02 is about a fiftieth of
/// a 53-degree view.
pub const MIN_INLIER_SPREAD: f64 = 0.02;
/// The previous frame's plane keeps its points (and is fitted again to them) while it fits at
/// least this share of the points the best new plane fits.
pub const KEEP_PREVIOUS_SHARE: f64 = 0.9;
/// The plane may come this many times nearer than the nearest point.
pub const NEAR_EXTRAPOLATION: f64 = 4.0;
/// A plane fitted to fewer inliers than this is not trusted.
const MIN_INLIERS: usize = 12;

/// `1/z = a x + b y + c` in the normalised coordinates `x = (u - cx) / fx`, `y = (v - cy) / fy`
/// of the camera it was fitted in (so every pyramid level of that camera shares it), with the
/// inverse depth clamped to `inverse_depth_range`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InverseDepthPlane {
    /// Coefficients `[a, b, c]`.
    pub coefficients: [f32; 3],
    /// The clamp of the plane's inverse depth (1/m): from the farthest point's to
    /// [`NEAR_EXTRAPOLATION`] times the nearest point's, so the plane never goes behind the
    /// camera or past the farthest point, and may come nearer than any point (a floor runs
    /// toward the camera beyond the points found on it) but not without bound.
    pub inverse_depth_range: [f32; 2],
}

impl InverseDepthPlane {
    /// The plane that fits most of `cloud` as `camera` sees it (points in front of it and inside
    /// its image), refined by least squares on its inliers; `None` when fewer than
    /// [`MIN_INLIERS`] points fit one.
    pub fn fit(camera: &Camera, cloud: &PointCloud) -> Option<Self> {
        Self::fit_points(camera, &cloud.positions_world, None)
    }

    /// [`Self::fit`] on the points' world positions alone. With `previous` (the plane of the
    /// frame before, streaming), the points that plane fits are kept while they are at least
    /// [`KEEP_PREVIOUS_SHARE`] as many as the best new plane's, and the plane is fitted again
    /// to them: a plane chosen afresh at every step jumps between near-equal fits, and the
    /// whole picture with it, while one kept as it was stays where the first frames put it
    /// (the keep-as-is form cost Pose2Sim's cam01 0.015 SSIM; `docs/RENDERER.md` item 9).
    pub fn fit_points(camera: &Camera, positions_world: &[[f32; 3]], previous: Option<&WorldPlane>) -> Option<Self> {
        let stride = positions_world.len().div_ceil(MAX_SAMPLES).max(1);
        let k = &camera.intrinsics;
        let samples: Vec<[f64; 3]> = positions_world
            .iter()
            .step_by(stride)
            .filter_map(|p| {
                let point_world = DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
                let (pixel, z) = camera.project_world(point_world)?;
                (z > 0.0 && z.is_finite() && camera.contains(pixel)).then(|| [(pixel.x - k.cx) / k.fx, (pixel.y - k.cy) / k.fy, 1.0 / z])
            })
            .collect();
        let previous = previous.and_then(|p| p.in_camera(camera));
        let [a, b, c] = fit_samples(&samples, previous)?;
        let (lo, hi) = samples.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), s| (lo.min(s[2]), hi.max(s[2])));
        Some(Self { coefficients: [a as f32, b as f32, c as f32], inverse_depth_range: [lo as f32, (hi * NEAR_EXTRAPOLATION) as f32] })
    }

    /// The same plane in world coordinates (`camera` is the one it was fitted in).
    pub fn to_world(&self, camera: &Camera) -> WorldPlane {
        // 1/z = a x + b y + c is n . X = 1 in the camera's frame with n = (a, b, c).
        let normal_camera = DVec3::from_array(self.coefficients.map(f64::from));
        let world_from_camera = camera.camera_from_world.inverse();
        let origin_camera = camera.camera_from_world.transform_point(DVec3::ZERO);
        WorldPlane {
            normal_world: world_from_camera.transform_vector(normal_camera).to_array(),
            offset: 1.0 - normal_camera.dot(origin_camera),
        }
    }

    /// The plane in the pixel coordinates of `camera` (any pyramid level of the camera it was
    /// fitted in).
    pub fn in_pixels(&self, camera: &Camera) -> PixelPlane {
        let k = &camera.intrinsics;
        let [a, b, c] = self.coefficients.map(f64::from);
        PixelPlane {
            coefficients: [(a / k.fx) as f32, (b / k.fy) as f32, (c - a * k.cx / k.fx - b * k.cy / k.fy) as f32],
            inverse_depth_range: self.inverse_depth_range,
        }
    }

    /// The plane's depth at every pixel of `camera`, row-major.
    pub fn depth_map(&self, camera: &Camera) -> Vec<f32> {
        let (w, h) = (camera.width_px as usize, camera.height_px as usize);
        let plane = self.in_pixels(camera);
        (0..w * h).map(|i| plane.depth_at(i % w, i / w)).collect()
    }
}

/// A plane in world coordinates, `normal_world . X = offset`: the plane of a frame, kept for
/// the next one (the camera may have moved).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldPlane {
    /// Its normal (any length).
    pub normal_world: [f64; 3],
    /// Its offset along the normal, in units of the normal's length.
    pub offset: f64,
}

impl WorldPlane {
    /// The coefficients `[a, b, c]` of [`InverseDepthPlane`] in `camera`; `None` when the plane
    /// passes through the camera's centre.
    fn in_camera(&self, camera: &Camera) -> Option<[f64; 3]> {
        let normal_camera = camera.camera_from_world.transform_vector(DVec3::from_array(self.normal_world));
        let origin_camera = camera.camera_from_world.transform_point(DVec3::ZERO);
        let scale = self.offset + normal_camera.dot(origin_camera);
        let coefficients = normal_camera / scale;
        (scale.abs() > 1e-12 && coefficients.is_finite()).then(|| coefficients.to_array())
    }
}

/// `1/z = a u + b v + c` in the pixels `(u, v)` of one camera, inverse depth clamped to
/// `inverse_depth_range`: what the depth system evaluates per pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelPlane {
    /// Coefficients `[a, b, c]` (1/m per pixel, per pixel, 1/m).
    pub coefficients: [f32; 3],
    /// Clamp of the inverse depth (1/m).
    pub inverse_depth_range: [f32; 2],
}

impl PixelPlane {
    /// The z-depth at pixel `(x, y)`. The GPU's `assemble/plane_support.wgsl` evaluates the same
    /// f32 expression.
    #[inline]
    pub fn depth_at(&self, x: usize, y: usize) -> f32 {
        let [a, b, c] = self.coefficients;
        1.0 / (a * x as f32 + b * y as f32 + c).clamp(self.inverse_depth_range[0], self.inverse_depth_range[1])
    }
}

/// Radius of the window in which [`plane_weights`] measures the points' support, in pixels of
/// the finest level (halved per coarser level, at least 1).
pub const SUPPORT_RADIUS_FINEST_PX: usize = 16;

/// The radius of that window at pyramid `level`, in the level's pixels.
pub fn support_radius_px(level: usize) -> usize {
    (SUPPORT_RADIUS_FINEST_PX >> level).max(1)
}

/// `lambda (1 - min(1, coverage / support))` per pixel, with `coverage` from
/// [`support_coverage`]. `support` is `RenderParams::plane_support` (or
/// `view_rank_support` with `lambda = 1`: how far each pixel is from the points' support).
pub fn plane_weights(mask: &ScalarRaster, level: usize, lambda: f32, support: f32) -> Vec<f32> {
    faded_weights(&support_coverage(mask, level), lambda, support)
}

/// `lambda (1 - min(1, coverage / support))` for each of `coverage` (as [`plane_weights`], from
/// a coverage computed once for several weights).
pub fn faded_weights(coverage: &[f32], lambda: f32, support: f32) -> Vec<f32> {
    coverage.iter().map(|&c| lambda * (1.0 - (c / support).min(1.0))).collect()
}

/// Per pixel, the share of pixels with a point (`mask > 0`) in the window of radius
/// [`support_radius_px`] around it, clipped to the image. The GPU's `plane_support.wgsl`
/// computes the same sums (integers, so exactly) and the same division.
pub fn support_coverage(mask: &ScalarRaster, level: usize) -> Vec<f32> {
    let (w, h) = (mask.width, mask.height);
    let r = support_radius_px(level);
    // Window counts along rows, then along columns of those, by running sums (counts are
    // integers: any order of summation gives the same).
    let mut rows = vec![0u32; w * h];
    let mut prefix = vec![0u32; w.max(h) + 1];
    for y in 0..h {
        for x in 0..w {
            prefix[x + 1] = prefix[x] + u32::from(mask.data[y * w + x] > 0.0);
        }
        for x in 0..w {
            rows[y * w + x] = prefix[(x + r).min(w - 1) + 1] - prefix[x.saturating_sub(r)];
        }
    }
    let mut out = vec![0.0f32; w * h];
    for x in 0..w {
        for y in 0..h {
            prefix[y + 1] = prefix[y] + rows[y * w + x];
        }
        let (xl, xh) = (x.saturating_sub(r), (x + r).min(w - 1));
        for y in 0..h {
            let (lo, hi) = (y.saturating_sub(r), (y + r).min(h - 1));
            let covered = (prefix[hi + 1] - prefix[lo]) as f32;
            let pixels = ((hi - lo + 1) * (xh - xl + 1)) as f32;
            out[y * w + x] = covered / pixels;
        }
    }
    out
}

/// RANSAC over `[x, y, 1/z]` samples, then least squares on the best hypothesis' inliers.
fn fit_samples(samples: &[[f64; 3]], previous: Option<[f64; 3]>) -> Option<[f64; 3]> {
    if samples.len() < MIN_INLIERS {
        return None;
    }
    let mut inverse: Vec<f64> = samples.iter().map(|s| s[2]).collect();
    inverse.sort_by(f64::total_cmp);
    let tolerance = inverse[inverse.len() / 2] * INLIER_SHARE;
    let residual = |p: &[f64; 3], s: &[f64; 3]| (p[0] * s[0] + p[1] * s[1] + p[2] - s[2]).abs();
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut next = |n: usize| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % n as u64) as usize
    };
    let mut best: Option<([f64; 3], usize)> = None;
    for _ in 0..HYPOTHESES {
        let picks = [next(samples.len()), next(samples.len()), next(samples.len())];
        let Some(plane) = least_squares(picks.iter().map(|&i| &samples[i])) else { continue };
        let inliers = samples.iter().filter(|s| residual(&plane, s) <= tolerance).count();
        if best.is_none_or(|(_, n)| inliers > n) {
            best = Some((plane, inliers));
        }
    }
    let (plane, inliers) = best?;
    if inliers < MIN_INLIERS {
        return None;
    }
    if let Some(previous) = previous {
        let kept: Vec<&[f64; 3]> = samples.iter().filter(|s| residual(&previous, s) <= tolerance).collect();
        if kept.len() as f64 >= KEEP_PREVIOUS_SHARE * inliers as f64 && narrowest_spread(&kept) >= MIN_INLIER_SPREAD {
            return least_squares(kept.iter().copied()).or(Some(previous));
        }
    }
    let inliers: Vec<&[f64; 3]> = samples.iter().filter(|s| residual(&plane, s) <= tolerance).collect();
    // A plane through one compact cluster (a person) tilts at random and swings far off
    // wherever it is extrapolated: its inliers must spread over the image in both directions.
    if narrowest_spread(&inliers) < MIN_INLIER_SPREAD {
        return None;
    }
    least_squares(inliers.iter().copied()).or(Some(plane))
}

/// The standard deviation of the samples' image positions along their narrowest direction.
fn narrowest_spread(samples: &[&[f64; 3]]) -> f64 {
    let n = samples.len().max(1) as f64;
    let (mx, my) = samples.iter().fold((0.0, 0.0), |(x, y), s| (x + s[0] / n, y + s[1] / n));
    let (sxx, syy, sxy) = samples.iter().fold((0.0, 0.0, 0.0), |(a, b, c), s| {
        (a + (s[0] - mx).powi(2) / n, b + (s[1] - my).powi(2) / n, c + (s[0] - mx) * (s[1] - my) / n)
    });
    let smallest = 0.5 * (sxx + syy) - (0.25 * (sxx - syy).powi(2) + sxy * sxy).sqrt();
    smallest.max(0.0).sqrt()
}

/// Least squares `1/z = a x + b y + c`.
fn least_squares<'a>(samples: impl Iterator<Item = &'a [f64; 3]>) -> Option<[f64; 3]> {
    let mut normal = DMat3::ZERO;
    let mut rhs = DVec3::ZERO;
    for s in samples {
        let row = DVec3::new(s[0], s[1], 1.0);
        normal += DMat3::from_cols(row * row.x, row * row.y, row * row.z);
        rhs += row * s[2];
    }
    // Relative to the matrix's scale, a near-zero determinant is a degenerate sample set.
    let scale = normal.x_axis.x.abs().max(normal.y_axis.y.abs()).max(normal.z_axis.z.abs());
    let determinant = normal.determinant().abs();
    if determinant.is_nan() || determinant <= 1e-12 * scale.powi(3) {
        return None;
    }
    let solution = normal.inverse() * rhs;
    solution.is_finite().then(|| solution.to_array())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Intrinsics, Rigid3};
    use glam::DVec3;

    fn camera() -> Camera {
        Camera {
            intrinsics: Intrinsics { fx: 100.0, fy: 100.0, cx: 40.0, cy: 30.0 },
            camera_from_world: Rigid3::IDENTITY,
            width_px: 80,
            height_px: 60,
        }
    }

    /// Points on the plane `z = 4 + 0.5 y` (a floor tilting away) and a third as many on a
    /// nearer blob: the fit finds the floor and reproduces its depth at the pixels.
    #[test]
    fn the_fit_finds_the_dominant_plane_and_ignores_the_rest() {
        let cam = camera();
        let mut cloud = PointCloud::default();
        for v in 0..20 {
            for u in 0..30 {
                let (xn, yn) = ((f64::from(u) * 2.5 - 40.0) / 100.0, (f64::from(v) * 3.0 - 30.0) / 100.0);
                // z = 4 + 0.5 * (y_world) with y_world = yn z: z = 4 / (1 - 0.5 yn).
                let z = 4.0 / (1.0 - 0.5 * yn);
                let p = cam.intrinsics.unproject(glam::DVec2::new(xn * 100.0 + 40.0, yn * 100.0 + 30.0), z);
                cloud.positions_world.push([p.x as f32, p.y as f32, p.z as f32]);
                cloud.colors.push([0; 3]);
            }
        }
        for i in 0..200 {
            cloud.positions_world.push([(i % 10) as f32 * 0.01, (i / 10) as f32 * 0.01, 1.5]);
            cloud.colors.push([0; 3]);
        }
        let plane = InverseDepthPlane::fit(&cam, &cloud).expect("a plane");
        for (x, y) in [(0, 0), (40, 30), (79, 59), (10, 50)] {
            let yn = (y as f64 - 30.0) / 100.0;
            let expected = (4.0 / (1.0 - 0.5 * yn)) as f32;
            // Inside the range the points span the plane is exact; outside it is clamped.
            let got = plane.in_pixels(&cam).depth_at(x, y);
            let lo = 1.0 / plane.inverse_depth_range[1];
            let hi = 1.0 / plane.inverse_depth_range[0];
            assert!((got - expected.clamp(lo, hi)).abs() < 1e-3 * expected, "({x}, {y}): {got} against {expected}");
        }
        // The same plane at half resolution gives the same depth at the same place.
        let half = cam.resized(40, 30);
        assert!((plane.in_pixels(&half).depth_at(20, 15) - plane.in_pixels(&cam).depth_at(40, 30)).abs() < 0.02);
    }

    #[test]
    fn too_few_points_or_points_behind_give_no_plane() {
        let cam = camera();
        let few = PointCloud { positions_world: vec![[0.0, 0.0, 2.0]; 5], colors: vec![[0; 3]; 5] };
        assert!(InverseDepthPlane::fit(&cam, &few).is_none());
        let behind = PointCloud { positions_world: vec![[0.0, 0.0, -2.0]; 100], colors: vec![[0; 3]; 100] };
        assert!(InverseDepthPlane::fit(&cam, &behind).is_none());
    }

    #[test]
    fn the_pull_fades_where_points_are_dense() {
        // Every other pixel of the left quarter carries a point; none elsewhere.
        let (w, h) = (200, 40);
        let mask = ScalarRaster::from_vec(w, h, (0..w * h).map(|i| if i % w < 50 && i % 2 == 0 { 1.0 } else { 0.0 }).collect()).unwrap();
        let weights = plane_weights(&mask, 0, 0.1, 0.05);
        assert_eq!(weights[20 * w + 10], 0.0, "among the points");
        assert_eq!(weights[20 * w + 199], 0.1, "far from them");
        // Within the window's reach of the block's edge the pull grows from 0 to full.
        let across: Vec<f32> = (50..50 + 2 * SUPPORT_RADIUS_FINEST_PX).map(|x| weights[20 * w + x]).collect();
        assert!(across.windows(2).all(|p| p[0] <= p[1]) && across[0] < 0.1 && across.last() == Some(&0.1), "{across:?}");
        // Coarser levels look at a smaller window (in their own pixels): 3 pixels past the block
        // the finest level's window still holds points, level 3's (radius 2) none.
        let coarse = plane_weights(&mask, 3, 0.1, 0.05);
        assert_eq!((weights[20 * w + 52], coarse[20 * w + 52]), (0.0, 0.1));
    }

    #[test]
    fn a_plane_through_one_small_cluster_is_not_trusted() {
        // A steeply tilted patch covering a fiftieth of the view: its own tilt is not to be
        // trusted across the whole image.
        let cam = camera();
        let mut cloud = PointCloud::default();
        for k in 0..100 {
            let (u, v) = (38.0 + f64::from(k % 10) * 0.4, 28.0 + f64::from(k / 10) * 0.4);
            let z = 1.0 / (0.5 + 2.0 * (u - 40.0) / 100.0);
            let p = cam.intrinsics.unproject(glam::DVec2::new(u, v), z);
            cloud.positions_world.push([p.x as f32, p.y as f32, p.z as f32]);
            cloud.colors.push([0; 3]);
        }
        assert_eq!(InverseDepthPlane::fit(&cam, &cloud), None);
        // The same patch four times wider in both directions is.
        let wide = PointCloud {
            positions_world: cloud.positions_world.iter().map(|p| [4.0 * p[0], 4.0 * p[1], p[2]]).collect(),
            colors: cloud.colors.clone(),
        };
        assert!(InverseDepthPlane::fit(&cam, &wide).is_some());
    }

    #[test]
    fn a_plane_moves_with_the_camera_and_the_previous_one_is_kept_while_it_fits() {
        // The floor y = 1 (camera y points down) seen from two cameras.
        let cam = Camera {
            intrinsics: Intrinsics { fx: 100.0, fy: 100.0, cx: 40.0, cy: 30.0 },
            camera_from_world: Rigid3::camera_from_world_looking_at(
                DVec3::new(0.0, -1.0, -4.0),
                DVec3::new(0.0, 1.0, 2.0),
                DVec3::new(0.0, -1.0, 0.0),
            ),
            width_px: 80,
            height_px: 60,
        };
        let moved = Camera {
            camera_from_world: Rigid3::camera_from_world_looking_at(
                DVec3::new(0.7, -1.2, -4.0),
                DVec3::new(0.0, 1.0, 2.0),
                DVec3::new(0.0, -1.0, 0.0),
            ),
            ..cam
        };
        let floor: Vec<[f32; 3]> = (0..400).map(|k| [(k % 20) as f32 * 0.2 - 2.0, 1.0, (k / 20) as f32 * 0.3]).collect();
        let plane = InverseDepthPlane::fit_points(&cam, &floor, None).expect("a plane");
        let world = plane.to_world(&cam);
        let again = world.in_camera(&cam).unwrap();
        for (a, b) in again.iter().zip(plane.coefficients) {
            assert!((a - f64::from(b)).abs() < 1e-5, "{again:?} against {plane:?}");
        }
        // In the moved camera, the carried plane gives the floor's true depth.
        let carried =
            InverseDepthPlane { coefficients: world.in_camera(&moved).unwrap().map(|v| v as f32), inverse_depth_range: [1e-3, 1e3] };
        let pixels = carried.in_pixels(&moved);
        for p in floor.iter().step_by(37) {
            let (pixel, z) = moved.project_world(DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))).unwrap();
            if moved.contains(pixel) {
                let inverse =
                    pixels.coefficients[0] as f64 * pixel.x + pixels.coefficients[1] as f64 * pixel.y + pixels.coefficients[2] as f64;
                assert!((1.0 / inverse - z).abs() < 1e-3 * z, "{} against {z}", 1.0 / inverse);
            }
        }
        // A previous plane tilted a little, still within the inlier tolerance of most points,
        // keeps its points and is fitted again to them (it lands on the floor, not where it
        // was); one tilted far is replaced by the new fit.
        let tilted = |angle: f64| {
            let n = DVec3::from_array(world.normal_world);
            let rotated = glam::DQuat::from_rotation_z(angle) * n;
            WorldPlane { normal_world: rotated.to_array(), offset: world.offset }
        };
        let fresh = InverseDepthPlane::fit_points(&moved, &floor, None).unwrap();
        let kept = InverseDepthPlane::fit_points(&moved, &floor, Some(&tilted(0.01))).unwrap();
        assert_ne!(kept.coefficients, tilted(0.01).in_camera(&moved).unwrap().map(|v| v as f32));
        for (a, b) in kept.coefficients.iter().zip(fresh.coefficients) {
            assert!((a - b).abs() < 1e-4 * (1.0 + b.abs()), "{kept:?} against {fresh:?}");
        }
        let refitted = InverseDepthPlane::fit_points(&moved, &floor, Some(&tilted(0.3))).unwrap();
        assert_eq!(refitted, fresh);
    }

    #[test]
    fn the_previous_plane_keeps_its_surface_among_near_equal_ones_and_is_fitted_to_it() {
        // Two walls facing the camera, 5 m away on the left and 10 m away on the right, 400
        // points each: a fit afresh takes either. Streaming from either, 1% off, the frame keeps
        // that wall (no jump between near-equal fits), fitted again to its points: it lands on
        // the wall, not where the previous plane was.
        let cam = Camera {
            intrinsics: Intrinsics { fx: 100.0, fy: 100.0, cx: 40.0, cy: 30.0 },
            camera_from_world: Rigid3::camera_from_world_looking_at(DVec3::ZERO, DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, -1.0, 0.0)),
            width_px: 80,
            height_px: 60,
        };
        let near = (0..400).map(|k| [(k % 20) as f32 * 0.09 - 1.9, (k / 20) as f32 * 0.1 - 1.0, 5.0]);
        let far = (0..400).map(|k| [(k % 20) as f32 * 0.18 + 0.4, (k / 20) as f32 * 0.2 - 2.0, 10.0]);
        let points: Vec<[f32; 3]> = near.chain(far).collect();
        assert!(
            points
                .iter()
                .all(|p| cam.project_world(DVec3::new(p[0].into(), p[1].into(), p[2].into())).is_some_and(|(px, _)| cam.contains(px)))
        );
        let depth_error = |plane: &InverseDepthPlane, p: DVec3| {
            let (pixel, z) = cam.project_world(p).unwrap();
            let c = plane.in_pixels(&cam).coefficients.map(f64::from);
            (1.0 / (c[0] * pixel.x + c[1] * pixel.y + c[2]) - z).abs() / z
        };
        let (on_near, on_far) = (DVec3::new(-1.0, 0.0, 5.0), DVec3::new(2.0, 0.0, 10.0));
        let near_off = WorldPlane { normal_world: [0.0, 0.0, 1.0], offset: 5.05 };
        let far_off = WorldPlane { normal_world: [0.0, 0.0, 1.0], offset: 10.1 };
        for (previous, on, off) in [(near_off, on_near, on_far), (far_off, on_far, on_near)] {
            let streamed = InverseDepthPlane::fit_points(&cam, &points, Some(&previous)).unwrap();
            assert!(depth_error(&streamed, on) < 1e-4, "{previous:?}: {}", depth_error(&streamed, on));
            assert!(depth_error(&streamed, off) > 0.05, "{previous:?}: {}", depth_error(&streamed, off));
        }
    }
}
