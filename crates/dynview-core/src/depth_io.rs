//! Depth maps as 16-bit PNG: `depth_m = value * meters_per_unit`, value 0 means "no depth".
//! A folder of such images carries its scale in `scale.json`.

use serde::{Deserialize, Serialize};

use crate::raster::ScalarRaster;

/// The file beside depth PNGs that holds their scale.
pub const SCALE_FILE: &str = "scale.json";

/// Contents of `scale.json`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DepthScale {
    /// Metres (scene units) per 16-bit step.
    pub meters_per_unit: f64,
    /// The stored value meaning "no depth".
    pub invalid_value: u16,
}

impl DepthScale {
    /// Millimetre steps: depths up to 65.534 m.
    pub const MILLIMETERS: Self = Self { meters_per_unit: 0.001, invalid_value: 0 };

    /// The finest scale that still represents depths up to `max_depth_m`, never finer than a
    /// tenth of a millimetre.
    pub fn for_max_depth(max_depth_m: f64) -> Self {
        let fine = if max_depth_m.is_finite() && max_depth_m > 0.0 { max_depth_m / 65_000.0 } else { 0.001 };
        Self { meters_per_unit: fine.max(1e-4), invalid_value: 0 }
    }

    /// Quantises a depth; non-finite or non-positive depths become `invalid_value`.
    pub fn encode(&self, depth_m: f32) -> u16 {
        if !(depth_m.is_finite() && depth_m > 0.0) {
            return self.invalid_value;
        }
        ((f64::from(depth_m) / self.meters_per_unit).round()).clamp(1.0, 65535.0) as u16
    }

    /// Decodes a stored value; `invalid_value` gives `None`.
    pub fn decode(&self, value: u16) -> Option<f32> {
        (value != self.invalid_value).then(|| (f64::from(value) * self.meters_per_unit) as f32)
    }
}

/// Encodes a depth raster as a 16-bit grayscale image.
pub fn depth_to_image(depth_m: &ScalarRaster, scale: DepthScale) -> image::ImageBuffer<image::Luma<u16>, Vec<u16>> {
    let data: Vec<u16> = depth_m.data.iter().map(|&d| scale.encode(d)).collect();
    image::ImageBuffer::from_raw(depth_m.width as u32, depth_m.height as u32, data)
        .unwrap_or_else(|| image::ImageBuffer::new(depth_m.width as u32, depth_m.height as u32))
}

/// Decodes a 16-bit depth image; missing depth becomes `f32::NAN`.
pub fn depth_from_image(image: &image::ImageBuffer<image::Luma<u16>, Vec<u16>>, scale: DepthScale) -> ScalarRaster {
    ScalarRaster {
        width: image.width() as usize,
        height: image.height() as usize,
        data: image.pixels().map(|p| scale.decode(p[0]).unwrap_or(f32::NAN)).collect(),
    }
}

/// Encodes a depth raster as 16-bit PNG bytes.
pub fn depth_png_bytes(depth_m: &ScalarRaster, scale: DepthScale) -> Result<Vec<u8>, image::ImageError> {
    let mut out = Vec::new();
    depth_to_image(depth_m, scale).write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn millimetre_round_trip_and_invalid() {
        let s = DepthScale::MILLIMETERS;
        assert_eq!(s.encode(1.2345), 1235);
        assert_eq!(s.decode(1235), Some(1.235));
        assert_eq!(s.encode(f32::NAN), 0);
        assert_eq!(s.encode(-1.0), 0);
        assert_eq!(s.encode(1e-6), 1);
        assert_eq!(s.encode(1e9), 65535);
        assert_eq!(s.decode(0), None);
    }

    #[test]
    fn scale_fits_the_range() {
        let s = DepthScale::for_max_depth(200.0);
        assert!(s.encode(200.0) < 65535);
        assert_eq!(DepthScale::for_max_depth(0.5).meters_per_unit, 1e-4);
    }

    #[test]
    fn png_round_trip() {
        let depth = ScalarRaster::from_vec(3, 2, vec![1.0, 2.5, f32::NAN, 0.25, 10.0, 3.333]).unwrap();
        let bytes = depth_png_bytes(&depth, DepthScale::MILLIMETERS).unwrap();
        let img = image::load_from_memory(&bytes).unwrap().into_luma16();
        let back = depth_from_image(&img, DepthScale::MILLIMETERS);
        for (a, b) in depth.data.iter().zip(&back.data) {
            assert!((a.is_nan() && b.is_nan()) || (a - b).abs() <= 0.0005, "{a} vs {b}");
        }
    }
}
