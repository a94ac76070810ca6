//! Focal lengths without calibration: self-calibration from fundamental matrices.
//!
//! With the principal point at the image centre and square pixels, `E = K_b^T F K_a` is an
//! essential matrix only for the right focal lengths, whose two non-zero singular values are
//! then equal (Mendonca and Cipolla, 1999). Every camera's focal is modelled as one shared
//! factor times its image's longer side; the factor minimising the inlier-weighted sum of
//! `(s1 - s2) / s1` over many pairs is the estimate, which bundle adjustment then refines per
//! camera. When the cost has no clear minimum (e.g. every optical axis meets at one point, a
//! known degenerate case) the usual prior of 1.2 times the longer side is kept.

use nalgebra::Matrix3;

/// The prior focal factor (times the longer image side) used when nothing better is known,
/// as COLMAP does.
pub const PRIOR_FOCAL_FACTOR: f64 = 1.2;
const GRID: usize = 160;
const FACTOR_RANGE: (f64, f64) = (0.25, 6.0);

/// A pair's fundamental matrix with the sizes of its two images and its inlier count.
#[derive(Clone, Copy, Debug)]
pub struct PairGeometry {
    /// Row-major `F` with `x_b^T F x_a = 0`, pixels with centres at integers.
    pub fundamental: [f64; 9],
    /// Image a's `(width, height)`.
    pub size_a: (u32, u32),
    /// Image b's `(width, height)`.
    pub size_b: (u32, u32),
    /// Inliers supporting `F`.
    pub inliers: usize,
}

fn k_matrix(factor: f64, (w, h): (u32, u32)) -> Matrix3<f64> {
    let f = factor * f64::from(w.max(h));
    Matrix3::new(f, 0.0, 0.5 * (f64::from(w) - 1.0), 0.0, f, 0.5 * (f64::from(h) - 1.0), 0.0, 0.0, 1.0)
}

/// The cost of a focal factor: inlier-weighted mean of `(s1 - s2) / s1`.
pub fn cost(pairs: &[PairGeometry], factor: f64) -> f64 {
    let (mut sum, mut weight) = (0.0, 0.0);
    for p in pairs {
        let f = Matrix3::from_row_slice(&p.fundamental);
        let e = k_matrix(factor, p.size_b).transpose() * f * k_matrix(factor, p.size_a);
        let s = e.singular_values();
        let mut s: Vec<f64> = s.iter().copied().collect();
        s.sort_by(|a, b| b.total_cmp(a));
        if s[0] > 0.0 && s[0].is_finite() {
            sum += p.inliers as f64 * (s[0] - s[1]) / s[0];
            weight += p.inliers as f64;
        }
    }
    if weight > 0.0 { sum / weight } else { f64::INFINITY }
}

/// The focal factor (focal = factor x longer image side) that best makes every pair's `F` an
/// essential matrix, or `None` when the minimum is not clear.
pub fn estimate_focal_factor(pairs: &[PairGeometry]) -> Option<f64> {
    if pairs.is_empty() {
        return None;
    }
    let (lo, hi) = (FACTOR_RANGE.0.ln(), FACTOR_RANGE.1.ln());
    let factors: Vec<f64> = (0..GRID).map(|i| (lo + (hi - lo) * i as f64 / (GRID - 1) as f64).exp()).collect();
    let costs: Vec<f64> = factors.iter().map(|&f| cost(pairs, f)).collect();
    let (best, &best_cost) = costs.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1))?;
    if best == 0 || best == GRID - 1 || !best_cost.is_finite() {
        return None;
    }
    // A clear minimum: well below the cost at half and double the factor.
    let at = |factor: f64| cost(pairs, factor);
    let f = factors[best];
    let contrast = at(f * 0.5).min(at(f * 2.0));
    if best_cost.partial_cmp(&(0.5 * contrast)) != Some(std::cmp::Ordering::Less) {
        return None;
    }
    // Golden-section refinement between the grid neighbours.
    let (mut a, mut b) = (factors[best - 1], factors[best + 1]);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..40 {
        let (c, d) = (b - g * (b - a), a + g * (b - a));
        if at(c) < at(d) { b = d } else { a = c }
    }
    Some(0.5 * (a + b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};

    #[test]
    fn recovers_the_focal_of_general_motion() {
        let size = (960, 540);
        let k = k_matrix(0.8, size);
        let mut pairs = Vec::new();
        for (axis, t) in
            [(Vector3::new(0.1, 0.3, 0.05), Vector3::new(1.0, 0.2, 0.3)), (Vector3::new(-0.2, 0.1, 0.1), Vector3::new(0.3, -1.0, 0.5))]
        {
            let r = Rotation3::from_scaled_axis(axis).into_inner();
            let e = t.cross_matrix() * r;
            let f = k.transpose().try_inverse().unwrap() * e * k.try_inverse().unwrap();
            let f = f / f.norm();
            let mut row = [0.0; 9];
            for i in 0..9 {
                row[i] = f[(i / 3, i % 3)];
            }
            pairs.push(PairGeometry { fundamental: row, size_a: size, size_b: size, inliers: 100 });
        }
        let factor = estimate_focal_factor(&pairs).unwrap();
        assert!((factor - 0.8).abs() < 1e-3, "{factor}");
    }
}
