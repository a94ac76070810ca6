//! The quantisation grid of `clouds.bin`: where positions and colors are rounded to when a
//! cloud is stored (16-bit positions and 8-bit colors in version 1; version 2 stores its grid in
//! the header).

/// The quantisation of a clouds file: positions on a grid of `2^position_bits` levels per axis
/// across the box, colors to `color_bits` per channel (16 and 8 in version 1; version 2 stores
/// its choice in the header).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Smallest corner of the box.
    pub bounds_min: [f32; 3],
    /// Largest corner of the box.
    pub bounds_max: [f32; 3],
    /// Bits per coordinate, 1 to 16.
    pub position_bits: u32,
    /// Bits per color channel, 4 to 8.
    pub color_bits: u32,
}

impl Grid {
    /// The 16-bit grid of `bounds`, 8-bit colors.
    pub fn full(bounds_min: [f32; 3], bounds_max: [f32; 3]) -> Self {
        Self { bounds_min, bounds_max, position_bits: 16, color_bits: 8 }
    }

    /// The coarsest grid of `bounds` whose step is at most `step` on every axis (16 bits at
    /// most), 8-bit colors.
    pub fn with_step(bounds_min: [f32; 3], bounds_max: [f32; 3], step: f64) -> Self {
        let extent = (0..3).map(|i| f64::from(bounds_max[i] - bounds_min[i])).fold(0.0, f64::max);
        let levels = if step > 0.0 && step.is_finite() { (extent / step).ceil() + 1.0 } else { f64::INFINITY };
        let position_bits = (1..=16).find(|&b| f64::from((1u32 << b) - 1) >= levels - 1.0).unwrap_or(16);
        Self { bounds_min, bounds_max, position_bits, color_bits: 8 }
    }

    /// A color channel on `color_bits` bits.
    pub fn quantise_color(&self, v: u8) -> u8 {
        v >> (8 - self.color_bits)
    }

    /// A color channel back on 8 bits, its bits repeated into the low ones (so the darkest and
    /// brightest levels stay 0 and 255).
    pub fn dequantise_color(&self, q: u8) -> u8 {
        let b = self.color_bits;
        if b >= 8 { q } else { (q << (8 - b)) | (q >> (2 * b - 8)) }
    }

    fn top(&self) -> f32 {
        ((1u32 << self.position_bits) - 1) as f32
    }

    /// The grid cell of `p` (clamped onto the box); `None` when not finite.
    pub fn quantise(&self, p: [f32; 3]) -> Option<[u16; 3]> {
        if p.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let top = self.top();
        Some(std::array::from_fn(|i| {
            let extent = self.bounds_max[i] - self.bounds_min[i];
            let inv = if extent > 0.0 { top / extent } else { 0.0 };
            ((p[i] - self.bounds_min[i]) * inv).round().clamp(0.0, top) as u16
        }))
    }

    /// The position of grid cell `q`.
    pub fn dequantise(&self, q: [u16; 3]) -> [f32; 3] {
        let top = self.top();
        std::array::from_fn(|i| self.bounds_min[i] + f32::from(q[i]) * ((self.bounds_max[i] - self.bounds_min[i]) / top))
    }
}
