//! An experimental fallback measured by `eval-real` (issue 15, part 2): the best-ranked input
//! view warped with a single plane fitted to the sparse depth the virtual camera sees. A plane
//! is wrong almost everywhere, but it warps a view as a homography: the picture stays a real,
//! undistorted photograph (sharp, no doubled or swirled texture), only slightly displaced.

use dynview_core::render::pushpull;
use dynview_core::render::sparse::project_cloud;
use dynview_core::render::warp::warp_view;
use dynview_core::scene::PointCloud;
use dynview_core::{Camera, RgbRaster, ScalarRaster};
use nalgebra::{Matrix3, Vector3};

/// RANSAC hypotheses of the plane fit.
const HYPOTHESES: usize = 256;
/// An inverse depth within this share of the median inverse depth fits the plane.
const INLIER_SHARE: f64 = 0.05;

/// The plane `1/z = a x + b y + c` (pixel coordinates of the virtual camera) that fits most
/// of `samples` (`(x, y, 1/z)`), refined by least squares on its inliers; `None` with fewer
/// than three samples or a degenerate fit.
pub fn fit_inverse_depth_plane(samples: &[(f64, f64, f64)]) -> Option<[f64; 3]> {
    if samples.len() < 3 {
        return None;
    }
    let mut inverse: Vec<f64> = samples.iter().map(|s| s.2).collect();
    inverse.sort_by(f64::total_cmp);
    let tolerance = inverse[inverse.len() / 2] * INLIER_SHARE;
    let residual = |p: &[f64; 3], s: &(f64, f64, f64)| (p[0] * s.0 + p[1] * s.1 + p[2] - s.2).abs();
    let mut best: Option<([f64; 3], usize)> = None;
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut next = |n: usize| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % n as u64) as usize
    };
    for _ in 0..HYPOTHESES {
        let picks = [next(samples.len()), next(samples.len()), next(samples.len())];
        let Some(plane) = least_squares(picks.iter().map(|&i| &samples[i])) else { continue };
        let inliers = samples.iter().filter(|s| residual(&plane, s) <= tolerance).count();
        if best.is_none_or(|(_, n)| inliers > n) {
            best = Some((plane, inliers));
        }
    }
    let (plane, _) = best?;
    least_squares(samples.iter().filter(|s| residual(&plane, s) <= tolerance)).or(Some(plane))
}

fn least_squares<'a>(samples: impl Iterator<Item = &'a (f64, f64, f64)>) -> Option<[f64; 3]> {
    let mut normal = Matrix3::<f64>::zeros();
    let mut rhs = Vector3::<f64>::zeros();
    for s in samples {
        let row = Vector3::new(s.0, s.1, 1.0);
        normal += row * row.transpose();
        rhs += row * s.2;
    }
    let solution = normal.lu().solve(&rhs)?;
    solution.iter().all(|v| v.is_finite()).then(|| [solution[0], solution[1], solution[2]])
}

/// The best-ranked input (`input`, seen by `input_camera`) warped into `camera` with the plane
/// fitted to `cloud`'s depth in `camera`; holes (off the input image, or where the plane is
/// behind the camera) filled by push-pull. `None` when the cloud gives no plane.
pub fn plane_view(camera: &Camera, cloud: &PointCloud, input_camera: &Camera, input: &RgbRaster) -> Option<RgbRaster> {
    let sparse = project_cloud(cloud, camera);
    let (w, h) = (sparse.depth.width, sparse.depth.height);
    let samples: Vec<(f64, f64, f64)> = (0..w * h)
        .filter(|&i| sparse.mask.data[i] > 0.0 && sparse.depth.data[i].is_finite() && sparse.depth.data[i] > 0.0)
        .map(|i| ((i % w) as f64, (i / w) as f64, 1.0 / f64::from(sparse.depth.data[i])))
        .collect();
    let plane = fit_inverse_depth_plane(&samples)?;
    let far = samples.iter().map(|s| s.2).fold(f64::INFINITY, f64::min).max(1e-9);
    let depth = ScalarRaster::from_vec(
        w,
        h,
        (0..w * h)
            .map(|i| {
                let inverse = plane[0] * (i % w) as f64 + plane[1] * (i / w) as f64 + plane[2];
                // Beyond the farthest sample (or behind the camera): the farthest sample's depth.
                (1.0 / inverse.max(far)) as f32
            })
            .collect(),
    )?;
    let warp = warp_view(camera, &depth, input_camera, input);
    let weights = ScalarRaster::from_vec(w, h, (0..w * h).map(|i| if warp.valid(i) { 1.0 } else { 0.0 }).collect())?;
    let color = RgbRaster::from_vec(w, h, warp.color)?;
    Some(pushpull::fill(&color, &weights, [0.5; 3]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plane_fit_ignores_outliers() {
        let plane = [0.001, -0.002, 0.5];
        let mut samples: Vec<(f64, f64, f64)> = (0..200)
            .map(|i| {
                let (x, y) = (f64::from(i % 20) * 10.0, f64::from(i / 20) * 10.0);
                (x, y, plane[0] * x + plane[1] * y + plane[2])
            })
            .collect();
        // A third of the samples on something nearer.
        samples.extend((0..100).map(|i| (f64::from(i), 50.0, 2.0)));
        let fit = fit_inverse_depth_plane(&samples).expect("a plane");
        for (a, b) in fit.iter().zip(plane) {
            assert!((a - b).abs() < 1e-9, "{fit:?}");
        }
        assert!(fit_inverse_depth_plane(&samples[..2]).is_none());
    }
}
