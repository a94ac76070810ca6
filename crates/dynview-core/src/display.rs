//! Turning render outputs into pictures: RGBA bytes for a canvas, false-color depth and view
//! weights. Shared by the viewer and the evaluation strips so both show the same thing.

use crate::raster::{Raster, RgbRaster, ScalarRaster, u8_from_unit};

/// What a display shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DisplayMode {
    /// The rendered color.
    Color,
    /// False-color depth, near yellow, far blue.
    Depth,
    /// `sum_s w_P^s`, how well the input views agree (black: none, white: all of them).
    Weights,
}

/// The 2nd and 98th percentiles of the finite values (the range a false-color map spans).
fn robust_range(values: &[f32]) -> (f32, f32) {
    let mut finite: Vec<f32> = values.iter().copied().filter(|d| d.is_finite()).collect();
    if finite.is_empty() {
        return (0.0, 1.0);
    }
    finite.sort_by(|a, b| a.total_cmp(b));
    (finite[finite.len() / 50], finite[finite.len() * 49 / 50])
}

/// A false-color depth image (near yellow, far blue), scaled between the 2nd and 98th
/// percentiles of the finite depths; non-finite depth is black.
pub fn colorize_depth(depth_m: &ScalarRaster) -> RgbRaster {
    let (lo, hi) = robust_range(&depth_m.data);
    depth_m.map(|d| {
        if !d.is_finite() {
            return [0.0; 3];
        }
        let u = ((d - lo) / (hi - lo).max(1e-6)).clamp(0.0, 1.0);
        [1.0 - u, 0.8 - 0.5 * u, 0.2 + 0.8 * u]
    })
}

/// Gray levels of the view weights `sum_s w_P^s`, scaled so that `views` agreeing views are
/// white.
pub fn colorize_weights(weights: &ScalarRaster, views: usize) -> RgbRaster {
    let scale = 1.0 / views.max(1) as f32;
    weights.map(|w| {
        let v = (w * scale).clamp(0.0, 1.0);
        [v, v, v]
    })
}

/// Opaque RGBA bytes of `image`, row-major, for a canvas `ImageData`.
pub fn to_rgba8(image: &RgbRaster) -> Vec<u8> {
    let mut out = Vec::with_capacity(image.data.len() * 4);
    for px in &image.data {
        out.extend_from_slice(&[u8_from_unit(px[0]), u8_from_unit(px[1]), u8_from_unit(px[2]), 255]);
    }
    out
}

/// The picture of a render for `mode`: color as is, depth or weights false-colored.
pub fn picture(mode: DisplayMode, color: &RgbRaster, depth_m: &ScalarRaster, weights: Option<&ScalarRaster>, views: usize) -> RgbRaster {
    match mode {
        DisplayMode::Color => color.clone(),
        DisplayMode::Depth => colorize_depth(depth_m),
        DisplayMode::Weights => match weights {
            Some(w) if w.width == color.width && w.height == color.height => colorize_weights(w, views),
            _ => Raster::filled(color.width, color.height, [0.0; 3]),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_colors_run_from_yellow_near_to_blue_far() {
        let depth = Raster::from_vec(100, 1, (0..100).map(|i| 1.0 + i as f32).collect()).unwrap();
        let c = colorize_depth(&depth);
        assert_eq!(c.data[0], [1.0, 0.8, 0.2]);
        let far = c.data[99];
        assert!((far[0] - 0.0).abs() < 1e-6 && (far[2] - 1.0).abs() < 1e-6, "{far:?}");
        // Monotone in between: blue grows with depth.
        assert!(c.data.windows(2).all(|w| w[1][2] >= w[0][2]));
    }

    #[test]
    fn non_finite_depth_is_black_and_does_not_move_the_range() {
        let depth = Raster::from_vec(3, 1, vec![1.0, f32::NAN, 2.0]).unwrap();
        let c = colorize_depth(&depth);
        assert_eq!(c.data[1], [0.0; 3]);
        assert_eq!(c.data[0], [1.0, 0.8, 0.2]);
    }

    #[test]
    fn rgba_is_opaque_and_rounded() {
        let img = Raster::from_vec(2, 1, vec![[0.0, 0.5, 1.0], [1.0, 1.0, 1.0]]).unwrap();
        assert_eq!(to_rgba8(&img), vec![0, 128, 255, 255, 255, 255, 255, 255]);
    }

    #[test]
    fn weights_are_scaled_by_the_view_count() {
        let w = Raster::from_vec(2, 1, vec![2.0, 8.0]).unwrap();
        let c = colorize_weights(&w, 4);
        assert_eq!(c.data, vec![[0.5; 3], [1.0; 3]]);
    }
}
