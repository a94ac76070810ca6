//! Matching guided by known poses: a feature is compared only with the features of the other
//! image that lie within a few pixels of its epipolar line, and Lowe's ratio test is taken among
//! those candidates. Across wide baselines, where the ratio test over a whole image rejects
//! most true matches (something similar is always somewhere), this keeps them; it needs no
//! index and is deterministic.

use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use dynview_camera::Radial;

use crate::features::sift::{DESCRIPTOR_LEN, Features};

/// Normalized homogeneous coordinates of every feature.
fn rays(features: &Features, intrinsics: &Radial) -> Vec<Vector3<f64>> {
    features
        .xy
        .iter()
        .map(|xy| {
            let n = intrinsics.normalized(nalgebra::Vector2::new(f64::from(xy[0]), f64::from(xy[1])));
            Vector3::new(n.x, n.y, 1.0)
        })
        .collect()
}

/// Squared Euclidean distance of two byte descriptors.
pub(crate) fn squared_distance(a: &[u8], b: &[u8]) -> u32 {
    a.iter().zip(b).map(|(x, y)| (i32::from(*x) - i32::from(*y)).pow(2) as u32).sum()
}

/// For every feature of `from`, its best candidate in `to` when it passes the ratio test among
/// the candidates within `max_epipolar_px` of its epipolar line (`line = e * ray`).
fn best_along_lines(
    from: (&Features, &[Vector3<f64>]),
    to: (&Features, &[Vector3<f64>], f64),
    e: &Matrix3<f64>,
    max_epipolar_px: f64,
    ratio: f32,
) -> Vec<Option<u32>> {
    let (to_features, to_rays, to_focal_px) = to;
    let ratio_sq = f64::from(ratio).powi(2);
    from.1
        .par_iter()
        .enumerate()
        .map(|(i, ray)| {
            let line = e * ray;
            let norm = line.x.hypot(line.y);
            if !(norm > 0.0 && norm.is_finite()) {
                return None;
            }
            // Distance in normalized coordinates, times the focal length: pixels.
            let limit = max_epipolar_px / to_focal_px * norm;
            let descriptor = &from.0.descriptors[i * DESCRIPTOR_LEN..(i + 1) * DESCRIPTOR_LEN];
            let (mut best, mut second) = ((u32::MAX, u32::MAX), u32::MAX);
            for (j, candidate) in to_rays.iter().enumerate() {
                if line.dot(candidate).abs() > limit {
                    continue;
                }
                let d = squared_distance(descriptor, &to_features.descriptors[j * DESCRIPTOR_LEN..(j + 1) * DESCRIPTOR_LEN]);
                if d < best.0 {
                    second = best.0;
                    best = (d, j as u32);
                } else if d < second {
                    second = d;
                }
            }
            let passes = best.0 != u32::MAX && (second == u32::MAX || f64::from(best.0) < ratio_sq * f64::from(second));
            passes.then_some(best.1)
        })
        .collect()
}

/// Mutual best matches of images `a` and `b` under the essential matrix `e` (`x_b^T E x_a = 0`
/// for normalized points), each within `max_epipolar_px` of the other's epipolar line and
/// passing the ratio test among the candidates there: pairs `[feature of a, feature of b]`.
pub fn guided_matches(
    a: (&Features, &Radial),
    b: (&Features, &Radial),
    e: &Matrix3<f64>,
    max_epipolar_px: f64,
    ratio: f32,
) -> Vec<[u32; 2]> {
    let (rays_a, rays_b) = (rays(a.0, a.1), rays(b.0, b.1));
    let ab = best_along_lines((a.0, &rays_a), (b.0, &rays_b, b.1.f), e, max_epipolar_px, ratio);
    let ba = best_along_lines((b.0, &rays_b), (a.0, &rays_a, a.1.f), &e.transpose(), max_epipolar_px, ratio);
    crate::features::matching::mutual(&ab, &ba)
}

/// [`guided_matches`] under a fundamental matrix in pixels (row-major, `x_b^T F x_a = 0`), for
/// images whose intrinsics are not known yet.
pub fn guided_matches_fundamental(a: &Features, b: &Features, fundamental: &[f64; 9], max_epipolar_px: f64, ratio: f32) -> Vec<[u32; 2]> {
    // Pixels as normalized coordinates: a unit focal at the origin.
    let pixels = Radial { f: 1.0, cx: 0.0, cy: 0.0, k1: 0.0, k2: 0.0 };
    guided_matches((a, &pixels), (b, &pixels), &Matrix3::from_row_slice(fundamental), max_epipolar_px, ratio)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynview_camera::Rigid3;

    use crate::estimators::geometry::essential_between;

    fn descriptor(seed: u32) -> Vec<u8> {
        (0..DESCRIPTOR_LEN as u32).map(|k| ((seed.wrapping_mul(2_654_435_761) ^ k.wrapping_mul(40_503)) >> 7) as u8).collect()
    }

    #[test]
    fn only_features_near_the_epipolar_line_can_match() {
        let k = Radial { f: 500.0, cx: 320.0, cy: 240.0, k1: 0.0, k2: 0.0 };
        let a = Rigid3::from_angle_axis_center(Vector3::zeros(), Vector3::new(-0.5, 0.0, 0.0));
        let b = Rigid3::from_angle_axis_center(Vector3::new(0.0, -0.1, 0.0), Vector3::new(0.5, 0.0, 0.0));
        let points = [Vector3::new(0.1, 0.2, 5.0), Vector3::new(-0.3, -0.1, 6.0), Vector3::new(0.4, 0.0, 4.0)];
        let project = |pose: &Rigid3, p: &Vector3<f64>| {
            let px = k.pixel(pose.project_normalized(p).expect("in front"));
            [px.x as f32, px.y as f32]
        };
        let mut fa = Features::default();
        let mut fb = Features::default();
        for (i, p) in points.iter().enumerate() {
            fa.xy.push(project(&a, p));
            fa.descriptors.extend(descriptor(i as u32));
            fb.xy.push(project(&b, p));
            fb.descriptors.extend(descriptor(i as u32));
        }
        // In b, feature 2's descriptor also appears far from its epipolar line: ignored there.
        fb.xy.push([project(&b, &points[2])[0], project(&b, &points[2])[1] + 40.0]);
        fb.descriptors.extend(descriptor(2));
        let e = essential_between(&a, &b);
        let mut matches = guided_matches((&fa, &k), (&fb, &k), &e, 2.0, 0.8);
        matches.sort();
        assert_eq!(matches, vec![[0, 0], [1, 1], [2, 2]]);
    }
}
