//! The per-pixel weights of METHOD.md: `w_P^s`, `w_D`, `w_H` (paper `w_D^`) and `w_T`.

use super::params::RenderParams;
use super::sparse::SplatMaps;
use super::warp::ViewWarp;
use crate::par;
use crate::raster::{Rgb, RgbRaster};

/// `exp(-||a - b||^2 / (2 sigma^2))`, the Gaussian color agreement shared by all weights.
#[inline]
pub fn agreement(a: Rgb, b: Rgb, sigma: f32) -> f32 {
    let d2 = (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2);
    (-d2 / (2.0 * sigma * sigma)).exp()
}

/// `w_P^s(x) = sigma_vis^s(x) exp(-||I^proj_s(x) - I_t(x)||^2 / (2 sigma^2))` (paper Eq. wP).
pub fn projection_weights(warp: &ViewWarp, color: &RgbRaster, sigma: f32) -> Vec<f32> {
    let mut out = vec![0.0f32; color.data.len()];
    par::for_each_row_mut(&mut out, color.width, |y, row| {
        let base = y * color.width;
        for (x, w) in row.iter_mut().enumerate() {
            let i = base + x;
            let vis = warp.visibility[i];
            *w = if vis > 0.0 { vis * agreement(warp.color[i], color.data[i], sigma) } else { 0.0 };
        }
    });
    out
}

/// `||grad I(x)||^2` by central differences (one-sided at the border), summed over RGB.
#[inline]
fn gradient_sq(color: &RgbRaster, x: usize, y: usize) -> f32 {
    let (w, h) = (color.width, color.height);
    let (xl, xr) = (x.saturating_sub(1), (x + 1).min(w - 1));
    let (yu, yd) = (y.saturating_sub(1), (y + 1).min(h - 1));
    let sx = if xr > xl { 1.0 / (xr - xl) as f32 } else { 0.0 };
    let sy = if yd > yu { 1.0 / (yd - yu) as f32 } else { 0.0 };
    let (l, r, u, d) = (color.get(xl, y), color.get(xr, y), color.get(x, yu), color.get(x, yd));
    (0..3).map(|k| ((r[k] - l[k]) * sx).powi(2) + ((d[k] - u[k]) * sy).powi(2)).sum()
}

/// `w_D(x) = sum_s w_P^s / ((||grad (u I)||^2 + eps_g)(sum_s sigma_vis^s + eps_v))` (paper Eq.
/// wD with our `eps` terms and gradient unit `u`), clamped to `[w_d_min, w_d_max]`.
pub fn depth_smoothness_weights(color: &RgbRaster, sum_wp: &[f32], sum_visibility: &[f32], params: &RenderParams) -> Vec<f32> {
    let mut out = vec![0.0f32; color.data.len()];
    par::for_each_row_mut(&mut out, color.width, |y, row| {
        for (x, w) in row.iter_mut().enumerate() {
            let i = y * color.width + x;
            let g = gradient_sq(color, x, y) * params.gradient_unit * params.gradient_unit + params.eps_gradient;
            let v = sum_visibility[i] + params.eps_visibility;
            *w = (sum_wp[i] / (g * v)).clamp(params.w_d_min, params.w_d_max);
        }
    });
    out
}

/// `w_H(x) = exp(-||I^(x) - I_t(x)||^2 / (2 sigma^2))` on pixels with a sparse point, 0 elsewhere
/// (paper Eq. wH).
pub fn sparse_weights(sparse: &SplatMaps, color: &RgbRaster, sigma: f32) -> Vec<f32> {
    sparse
        .mask
        .data
        .iter()
        .zip(&sparse.color.data)
        .zip(&color.data)
        .map(|((&m, &s), &c)| if m > 0.0 { agreement(s, c, sigma) } else { 0.0 })
        .collect()
}

/// `w_T(x) = 1/n sum_s exp(-||I^proj_{t-1}(x) - I^proj_s(x)||^2 / (2 sigma^2))` (paper Eq. wT),
/// averaged over the views that are valid at `x`, and 0 where the previous frame does not cover
/// `x` or no view is valid.
pub fn temporal_weights(previous: &SplatMaps, warps: &[ViewWarp], sigma: f32) -> Vec<f32> {
    let n = previous.mask.data.len();
    (0..n)
        .map(|i| {
            if previous.mask.data[i] <= 0.0 {
                return 0.0;
            }
            let (sum, count) = warps
                .iter()
                .filter(|w| w.valid(i))
                .fold((0.0f32, 0u32), |(s, c), w| (s + agreement(previous.color.data[i], w.color[i], sigma), c + 1));
            if count == 0 { 0.0 } else { sum / count as f32 }
        })
        .collect()
}

/// Per chosen view, `r_s^gamma - 1`: how much the rank preference of
/// `RenderParams::view_rank_exponent` (`gamma`) changes view `s`'s `w_P^s` where no point
/// supports the depth, from its rank score relative to the best (`relative_rank`, 1 for the
/// best view: no change). The GPU takes these same values.
pub fn rank_preferences(relative_rank: &[f32], exponent: f32) -> Vec<f32> {
    relative_rank.iter().map(|r| r.powf(exponent) - 1.0).collect()
}

/// Scales each view's `w_P^s` by `1 + u preference_s`, where `u` (`unsupported`, per pixel, in
/// [0, 1]) is how far the pixel is from the points' support
/// (`plane::faded_weights(coverage, 1, view_rank_support)`): the best-ranked view's color
/// wins where depth is unsure, every view counts alike where points are dense. The GPU's
/// `assemble/rank_preference.wgsl` does the same.
pub fn apply_rank_preference(w_p: &mut [Vec<f32>], preferences: &[f32], unsupported: &[f32]) {
    for (w, &preference) in w_p.iter_mut().zip(preferences) {
        if preference == 0.0 {
            continue;
        }
        for (v, &u) in w.iter_mut().zip(unsupported) {
            *v *= 1.0 + u * preference;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agreement_hand_checked() {
        assert_eq!(agreement([0.2; 3], [0.2; 3], 0.075), 1.0);
        // ||d||^2 = 3 * 0.075^2 -> exp(-1.5).
        let w = agreement([0.0; 3], [0.075; 3], 0.075);
        assert!((w - (-1.5f32).exp()).abs() < 1e-6);
    }

    #[test]
    fn rank_preference_only_where_unsupported() {
        // Two views agreeing equally well; the second ranks at 1e-4 of the best.
        let prefs = rank_preferences(&[1.0, 1e-4], 1.0);
        assert_eq!(prefs[0], 0.0, "the best view keeps its weight");
        let mut w_p = vec![vec![0.8, 0.8, 0.8], vec![0.8, 0.8, 0.8]];
        // Pixel 0 has points around it, pixel 1 is halfway, pixel 2 has none.
        apply_rank_preference(&mut w_p, &prefs, &[0.0, 0.5, 1.0]);
        assert_eq!(w_p[0], vec![0.8; 3]);
        assert_eq!(w_p[1][0], 0.8, "dense points: every view alike");
        assert!((w_p[1][1] - 0.4).abs() < 1e-3, "{:?}", w_p[1]);
        assert!(w_p[1][2] < 1e-3, "no points: the best view wins: {:?}", w_p[1]);
        // An exponent of 0 changes nothing.
        assert!(rank_preferences(&[1.0, 1e-4], 0.0).iter().all(|&p| p == 0.0));
    }

    #[test]
    fn color_edge_lowers_w_d() {
        // Left half dark, right half bright: w_D must drop at the edge.
        let color = RgbRaster::from_vec(8, 3, (0..24).map(|i| if i % 8 < 4 { [0.1; 3] } else { [0.9; 3] }).collect()).unwrap();
        let ones = vec![1.0f32; 24];
        let params = RenderParams::default();
        let w = depth_smoothness_weights(&color, &ones, &ones, &params);
        let flat = w[8];
        let edge = w[8 + 3];
        assert!(edge < 0.05 * flat, "edge {edge} flat {flat}");
        // Disagreeing views (sum w_P small relative to visibility) lower it too.
        let low = vec![0.1f32; 24];
        let w_low = depth_smoothness_weights(&color, &low, &ones, &params);
        assert!(w_low[8] < flat);
    }
}

#[cfg(test)]
mod more_tests {
    use super::*;
    use crate::camera::{Camera, Intrinsics, Rigid3};
    use crate::raster::{Raster, ScalarRaster};
    use crate::render::warp::{compute_visibility, warp_view};

    #[test]
    fn outlier_sparse_point_gets_low_w_h() {
        let color = RgbRaster::filled(4, 1, [0.3, 0.5, 0.2]);
        let mut sparse = SplatMaps {
            depth: ScalarRaster::filled(4, 1, f32::INFINITY),
            color: Raster::filled(4, 1, [0.0; 3]),
            mask: ScalarRaster::filled(4, 1, 0.0),
        };
        // Pixel 1: a point of the surface's color; pixel 2: an outlier of another color.
        for (i, c) in [(1, [0.31, 0.5, 0.21]), (2, [0.9, 0.1, 0.8])] {
            sparse.depth.data[i] = 3.0;
            sparse.color.data[i] = c;
            sparse.mask.data[i] = 1.0;
        }
        let w_h = sparse_weights(&sparse, &color, 0.075);
        assert_eq!(w_h[0], 0.0, "no point, no weight");
        assert!(w_h[1] > 0.9, "{w_h:?}");
        assert!(w_h[2] < 0.01, "{w_h:?}");
    }

    #[test]
    fn moving_object_lowers_w_t() {
        // The current input shows gray on the left half and a red object on the right half; the
        // previous frame showed gray everywhere (the object moved in on the right).
        let cam = Camera {
            intrinsics: Intrinsics::from_vertical_fov(0.8, 16, 8),
            camera_from_world: Rigid3::IDENTITY,
            width_px: 16,
            height_px: 8,
        };
        let image = RgbRaster::from_vec(16, 8, (0..128).map(|i| if i % 16 < 8 { [0.5; 3] } else { [0.9, 0.1, 0.1] }).collect()).unwrap();
        let depth = ScalarRaster::filled(16, 8, 3.0);
        let mut warp = warp_view(&cam, &depth, &cam, &image);
        compute_visibility(&mut warp, 128, 0.02);
        let previous =
            SplatMaps { depth: depth.clone(), color: RgbRaster::filled(16, 8, [0.5; 3]), mask: ScalarRaster::filled(16, 8, 1.0) };
        let w_t = temporal_weights(&previous, &[warp], 0.075);
        assert!(w_t[4 * 16 + 2] > 0.99, "static pixel {}", w_t[4 * 16 + 2]);
        assert!(w_t[4 * 16 + 12] < 0.01, "moving pixel {}", w_t[4 * 16 + 12]);
        // No previous frame at a pixel: no temporal weight.
        let mut holes = previous.clone();
        holes.mask.data[0] = 0.0;
        let image2 = warp_view(&cam, &depth, &cam, &image);
        assert_eq!(temporal_weights(&holes, &[image2], 0.075)[0], 0.0);
    }
}
