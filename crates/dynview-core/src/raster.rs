//! Row-major pixel grids and their conversion to and from 8-bit images.
//!
//! Colors are `[f32; 3]` holding the 8-bit code values divided by 255 (no gamma decoding): the
//! paper's `sigma = 0.075` was chosen on such values, and PSNR is measured on them.

use serde::{Deserialize, Serialize};

/// An RGB color with channels in `[0, 1]`.
pub type Rgb = [f32; 3];

/// A row-major grid of pixels.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Raster<T> {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height` pixels, row by row.
    pub data: Vec<T>,
}

/// A color image.
pub type RgbRaster = Raster<Rgb>;
/// A single-channel image (depth, weights, masks).
pub type ScalarRaster = Raster<f32>;

impl<T: Copy> Raster<T> {
    /// A raster filled with `value`.
    pub fn filled(width: usize, height: usize, value: T) -> Self {
        Self { width, height, data: vec![value; width * height] }
    }

    /// Wraps existing data; `None` when `data.len() != width * height`.
    pub fn from_vec(width: usize, height: usize, data: Vec<T>) -> Option<Self> {
        (width.checked_mul(height)? == data.len()).then_some(Self { width, height, data })
    }

    /// The pixel at column `x`, row `y` (panics when out of bounds, like slice indexing).
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> T {
        self.data[y * self.width + x]
    }

    /// Sets the pixel at column `x`, row `y`.
    #[inline]
    pub fn set(&mut self, x: usize, y: usize, value: T) {
        self.data[y * self.width + x] = value;
    }

    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// True for a raster without pixels.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Applies `f` to every pixel.
    pub fn map<U>(&self, f: impl Fn(T) -> U) -> Raster<U> {
        Raster { width: self.width, height: self.height, data: self.data.iter().map(|&v| f(v)).collect() }
    }
}

/// Converts an 8-bit code value to `[0, 1]`.
#[inline]
pub fn unit_from_u8(v: u8) -> f32 {
    f32::from(v) * (1.0 / 255.0)
}

/// Converts a `[0, 1]` value to the nearest 8-bit code value (clamped; NaN maps to 0).
#[inline]
pub fn u8_from_unit(v: f32) -> u8 {
    // `as` saturates and maps NaN to 0.
    (v * 255.0 + 0.5) as u8
}

impl RgbRaster {
    /// Converts an 8-bit RGB image.
    pub fn from_rgb8(image: &image::RgbImage) -> Self {
        let (w, h) = image.dimensions();
        Self {
            width: w as usize,
            height: h as usize,
            data: image.pixels().map(|p| [unit_from_u8(p[0]), unit_from_u8(p[1]), unit_from_u8(p[2])]).collect(),
        }
    }

    /// Converts to an 8-bit RGB image (values clamped to `[0, 1]`).
    pub fn to_rgb8(&self) -> image::RgbImage {
        let mut bytes = Vec::with_capacity(self.data.len() * 3);
        for p in &self.data {
            bytes.extend(p.iter().map(|&c| u8_from_unit(c)));
        }
        // Dimensions match the buffer by construction.
        image::RgbImage::from_raw(self.width as u32, self.height as u32, bytes)
            .unwrap_or_else(|| image::RgbImage::new(self.width as u32, self.height as u32))
    }

    /// Bilinear sample at continuous pixel coordinates (pixel centres at integers). Returns
    /// `None` outside `[0, W-1] x [0, H-1]` extended by half a pixel (clamped at the border).
    pub fn sample_bilinear(&self, x: f32, y: f32) -> Option<Rgb> {
        let (w, h) = (self.width as f32, self.height as f32);
        if !(x >= -0.5 && y >= -0.5 && x < w - 0.5 && y < h - 0.5) {
            return None;
        }
        let xc = x.clamp(0.0, w - 1.0);
        let yc = y.clamp(0.0, h - 1.0);
        let x0 = xc.floor() as usize;
        let y0 = yc.floor() as usize;
        let x1 = (x0 + 1).min(self.width - 1);
        let y1 = (y0 + 1).min(self.height - 1);
        let fx = xc - x0 as f32;
        let fy = yc - y0 as f32;
        let (a, b, c, d) = (self.get(x0, y0), self.get(x1, y0), self.get(x0, y1), self.get(x1, y1));
        let mut out = [0.0; 3];
        for k in 0..3 {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            out[k] = top + (bottom - top) * fy;
        }
        Some(out)
    }
}

/// The maximum of `mask` (non-negative values) over a square window of side `2 radius + 1`
/// (rows, then columns).
pub fn dilated(mask: &ScalarRaster, radius: usize) -> ScalarRaster {
    window_extreme(mask, radius, |a, b| if b > a { b } else { a })
}

/// The minimum of `raster` over a square window of side `2 radius + 1` (rows, then columns;
/// infinite values stand for none).
pub fn min_filtered(raster: &ScalarRaster, radius: usize) -> ScalarRaster {
    window_extreme(raster, radius, |a, b| if b < a { b } else { a })
}

/// The mean of `raster` over a square window of side `2 radius + 1`, the window cut at the
/// image's edges: the window sums (separable, whole shifted rows as [`dilated`]) over the cut
/// window's size.
pub fn box_filtered(raster: &ScalarRaster, radius: usize) -> ScalarRaster {
    let (w, h) = (raster.width, raster.height);
    let mut out = window_extreme(raster, radius, |a, b| a + b);
    // The cut window at (x, y) spans `count(x, w)` columns and `count(y, h)` rows.
    let count = |i: usize, n: usize| ((i + radius).min(n - 1) - i.saturating_sub(radius) + 1) as f32;
    let column_counts: Vec<f32> = (0..w).map(|x| count(x, w)).collect();
    for (y, row) in out.data.chunks_exact_mut(w.max(1)).enumerate() {
        let rows = count(y, h);
        row.iter_mut().zip(&column_counts).for_each(|(v, &columns)| *v /= rows * columns);
    }
    out
}

/// `raster` with each pixel replaced by the `pick` of the pixels in its square window of side
/// `2 radius + 1`, separably: along rows, then along columns. Each pass combines whole shifted
/// rows, in memory order, so that it vectorizes.
fn window_extreme(raster: &ScalarRaster, radius: usize, pick: impl Fn(f32, f32) -> f32 + Copy) -> ScalarRaster {
    let (w, h) = (raster.width, raster.height);
    let mut rows = raster.data.clone();
    if w == 0 || h == 0 {
        return Raster { width: w, height: h, data: rows };
    }
    let combine = |dst: &mut [f32], src: &[f32]| dst.iter_mut().zip(src).for_each(|(a, &b)| *a = pick(*a, b));
    for (src, dst) in raster.data.chunks_exact(w).zip(rows.chunks_exact_mut(w)) {
        for d in 1..=radius.min(w - 1) {
            combine(&mut dst[..w - d], &src[d..]);
            combine(&mut dst[d..], &src[..w - d]);
        }
    }
    let mut out = rows.clone();
    for (y, dst) in out.chunks_exact_mut(w).enumerate() {
        for k in (y.saturating_sub(radius)..=(y + radius).min(h - 1)).filter(|&k| k != y) {
            combine(dst, &rows[k * w..(k + 1) * w]);
        }
    }
    Raster { width: w, height: h, data: out }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `pick` of every pixel's square window, pixel by pixel.
    fn brute_force(r: &ScalarRaster, radius: usize, pick: fn(f32, f32) -> f32, start: f32) -> Vec<f32> {
        let (w, h) = (r.width, r.height);
        (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let mut v = start;
                for yy in y.saturating_sub(radius)..=(y + radius).min(h - 1) {
                    for xx in x.saturating_sub(radius)..=(x + radius).min(w - 1) {
                        v = pick(v, r.data[yy * w + xx]);
                    }
                }
                v
            })
            .collect()
    }

    #[test]
    fn box_filtered_means_are_the_window_means() {
        let data: Vec<f32> = (0..7 * 5).map(|i| ((i * 37) % 11) as f32).collect();
        let r = Raster { width: 7, height: 5, data };
        for radius in [0, 1, 3, 9] {
            let got = box_filtered(&r, radius);
            for y in 0..5usize {
                for x in 0..7usize {
                    let (mut sum, mut n) = (0.0, 0.0);
                    for yy in y.saturating_sub(radius)..=(y + radius).min(4) {
                        for xx in x.saturating_sub(radius)..=(x + radius).min(6) {
                            sum += r.data[yy * 7 + xx];
                            n += 1.0;
                        }
                    }
                    assert!((got.data[y * 7 + x] - sum / n).abs() < 1e-5, "radius {radius} at ({x}, {y})");
                }
            }
        }
    }

    #[test]
    fn window_maxima_and_minima_match_a_pixel_by_pixel_search() {
        // A fixed pseudo-random pattern with runs of zeros and infinite values.
        let mut state = 12345u32;
        let mut next = || {
            state = state.wrapping_mul(1_103_515_245).wrapping_add(12345);
            (state >> 16) as f32 / 65536.0
        };
        for (w, h) in [(1, 1), (7, 3), (23, 17), (5, 40)] {
            let data: Vec<f32> = (0..w * h).map(|_| next()).map(|v| if v < 0.4 { 0.0 } else { v }).collect();
            let mask = Raster { width: w, height: h, data };
            let depth = Raster { width: w, height: h, data: mask.data.iter().map(|&v| if v == 0.0 { f32::INFINITY } else { v }).collect() };
            for radius in [0, 1, 2, 6, 30] {
                assert_eq!(dilated(&mask, radius).data, brute_force(&mask, radius, f32::max, 0.0), "{w}x{h} radius {radius}");
                assert_eq!(
                    min_filtered(&depth, radius).data,
                    brute_force(&depth, radius, f32::min, f32::INFINITY),
                    "{w}x{h} radius {radius}"
                );
            }
        }
    }

    #[test]
    fn u8_round_trip_is_exact() {
        for v in 0..=255u8 {
            assert_eq!(u8_from_unit(unit_from_u8(v)), v);
        }
        assert_eq!(u8_from_unit(-1.0), 0);
        assert_eq!(u8_from_unit(2.0), 255);
        assert_eq!(u8_from_unit(f32::NAN), 0);
    }

    #[test]
    fn rgb8_round_trip() {
        let img = image::RgbImage::from_fn(5, 3, |x, y| image::Rgb([x as u8 * 40, y as u8 * 90, 7]));
        let raster = RgbRaster::from_rgb8(&img);
        assert_eq!((raster.width, raster.height), (5, 3));
        assert_eq!(raster.to_rgb8(), img);
    }

    #[test]
    fn bilinear_hand_checked() {
        let r = RgbRaster::from_vec(2, 2, vec![[0.0; 3], [1.0; 3], [0.5; 3], [0.25; 3]]).unwrap();
        assert_eq!(r.sample_bilinear(0.0, 0.0), Some([0.0; 3]));
        // Centre: mean of the four.
        let c = r.sample_bilinear(0.5, 0.5).unwrap();
        assert!((c[0] - 0.4375).abs() < 1e-7);
        // Border half pixel is clamped, beyond is outside.
        assert_eq!(r.sample_bilinear(-0.4, 0.0), Some([0.0; 3]));
        assert_eq!(r.sample_bilinear(-0.6, 0.0), None);
        assert_eq!(r.sample_bilinear(1.5, 0.0), None);
        assert_eq!(r.sample_bilinear(f32::NAN, 0.0), None);
    }

    #[test]
    fn from_vec_checks_size() {
        assert!(ScalarRaster::from_vec(3, 2, vec![0.0; 5]).is_none());
        assert!(ScalarRaster::from_vec(usize::MAX, 2, vec![]).is_none());
    }
}
