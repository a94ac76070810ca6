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
    let (w, h) = (mask.width, mask.height);
    let mut rows = vec![0.0f32; w * h];
    for y in 0..h {
        let row = &mask.data[y * w..(y + 1) * w];
        for x in 0..w {
            rows[y * w + x] = row[x.saturating_sub(radius)..(x + radius + 1).min(w)].iter().fold(0.0, |a, &b| a.max(b));
        }
    }
    let mut out = vec![0.0f32; w * h];
    for x in 0..w {
        for y in 0..h {
            out[y * w + x] = (y.saturating_sub(radius)..(y + radius + 1).min(h)).map(|k| rows[k * w + x]).fold(0.0, f32::max);
        }
    }
    Raster { width: w, height: h, data: out }
}

#[cfg(test)]
mod tests {
    use super::*;

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
