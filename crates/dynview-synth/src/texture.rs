//! Procedural, non-periodic surface textures rich in blob-like features (for SIFT).
//!
//! Each texture is a function of a 3D point in the object's own frame, so the pattern moves
//! and turns with the object. It mixes hashed value noise (several octaves) with hashed spots.
//! The lattice hash has no period over any range a scene uses, so nothing repeats (a periodic
//! texture made COLMAP converge to a confidently wrong model in a trial here).

use glam::DVec3;

/// Parameters of one object's texture. With both frequencies 0 it is plain: the palette's
/// first color everywhere ([`Texture::plain`]).
#[derive(Clone, Copy, Debug)]
pub struct Texture {
    /// Seed of the hash; differs per object.
    pub seed: u64,
    /// Lattice frequency of the lowest noise octave, in cycles per metre.
    pub base_frequency: f64,
    /// Spot cells per metre.
    pub spot_frequency: f64,
    /// Two base colors mixed by the noise.
    pub palette: [[f32; 3]; 2],
}

#[inline]
fn mix64(mut h: u64) -> u64 {
    // splitmix64 finaliser.
    h ^= h >> 30;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 27;
    h = h.wrapping_mul(0x94D0_49BB_1331_11EB);
    h ^ (h >> 31)
}

#[inline]
fn hash3(x: i64, y: i64, z: i64, seed: u64) -> u64 {
    mix64(
        seed ^ (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ (z as u64).wrapping_mul(0x1656_67B1_9E37_79F9),
    )
}

/// Three values in `[0, 1)` from one hash (21 bits each).
#[inline]
fn unit3(h: u64) -> [f32; 3] {
    const SCALE: f32 = 1.0 / (1u64 << 21) as f32;
    [(h & 0x1F_FFFF) as f32 * SCALE, ((h >> 21) & 0x1F_FFFF) as f32 * SCALE, ((h >> 42) & 0x1F_FFFF) as f32 * SCALE]
}

#[inline]
fn fade(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}

/// Three-channel trilinear value noise in `[0, 1)`.
fn value_noise3(p: DVec3, seed: u64) -> [f32; 3] {
    let base = p.floor();
    let (ix, iy, iz) = (base.x as i64, base.y as i64, base.z as i64);
    let f = p - base;
    let (u, v, w) = (fade(f.x as f32), fade(f.y as f32), fade(f.z as f32));
    let mut out = [0.0f32; 3];
    for dz in 0..2 {
        let wz = if dz == 0 { 1.0 - w } else { w };
        for dy in 0..2 {
            let wy = if dy == 0 { 1.0 - v } else { v };
            for dx in 0..2 {
                let wx = if dx == 0 { 1.0 - u } else { u };
                let c = unit3(hash3(ix + dx, iy + dy, iz + dz, seed));
                let weight = wx * wy * wz;
                for k in 0..3 {
                    out[k] += weight * c[k];
                }
            }
        }
    }
    out
}

const OCTAVES: u32 = 6;

/// Fractal sum of value noise, normalised to roughly `[0, 1]`.
fn fbm3(p: DVec3, seed: u64) -> [f32; 3] {
    let mut sum = [0.0f32; 3];
    let mut amplitude = 1.0f32;
    let mut total = 0.0f32;
    let mut q = p;
    for octave in 0..OCTAVES {
        let n = value_noise3(q, seed.wrapping_add(u64::from(octave) * 0x51_7CC1_B727_220A));
        for k in 0..3 {
            sum[k] += amplitude * n[k];
        }
        total += amplitude;
        amplitude *= 0.72;
        // Scale by a non-integer factor and shift so octave lattices never align.
        q = q * 2.03 + DVec3::new(17.13, -5.71, 9.37);
    }
    sum.map(|s| s / total)
}

fn smoothstep(lo: f32, hi: f32, x: f32) -> f32 {
    let t = ((x - lo) / (hi - lo)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl Texture {
    fn spot(&self, q: DVec3, salt: u64) -> Option<[f32; 3]> {
        let cell = q.floor();
        let h = hash3(cell.x as i64, cell.y as i64, cell.z as i64, self.seed ^ salt);
        let r = unit3(h);
        if r[0] >= 0.6 {
            return None;
        }
        let radius = 0.12 + 0.22 * f64::from(r[1]);
        let h2 = mix64(h);
        let o = unit3(h2);
        let centre = cell + DVec3::new(f64::from(o[0]), f64::from(o[1]), f64::from(o[2])) * (1.0 - 2.0 * radius) + DVec3::splat(radius);
        if (q - centre).length() >= radius {
            return None;
        }
        let col = unit3(mix64(h2));
        Some(if r[2] < 0.5 { col.map(|v| 0.04 + 0.2 * v) } else { col.map(|v| 0.6 + 0.4 * v) })
    }

    /// Albedo at a point in the object's frame (metres).
    pub fn albedo(&self, p_local: DVec3) -> [f32; 3] {
        if self.is_plain() {
            return self.palette[0];
        }
        let n = fbm3(p_local * self.base_frequency, self.seed);
        // Stretch the noise (fbm concentrates around 0.5) into strong blobs.
        let m = smoothstep(0.42, 0.58, n[0]);
        let [a, b] = self.palette;
        let mut c: [f32; 3] = std::array::from_fn(|k| a[k] + (b[k] - a[k]) * m);
        // Hue and brightness variation from the other channels.
        let tint = (n[1] - 0.5) * 0.9;
        let bright = 0.3 + 0.95 * smoothstep(0.38, 0.62, n[2]);
        c = [c[0] * bright + tint * 0.3, c[1] * bright - tint * 0.1, c[2] * bright - tint * 0.25];

        // Spots at two scales: at most one disc per cell, fully inside it, of random size and
        // color.
        for (scale, salt) in [(1.0, 0xA5A5_5A5A_1234_4321u64), (2.7, 0x0F0F_F0F0_5678_8765)] {
            if let Some(spot) = self.spot(p_local * (self.spot_frequency * scale), salt) {
                c = spot;
            }
        }
        c.map(|v| v.clamp(0.0, 1.0))
    }
}

impl Texture {
    /// A plain color, no pattern: nothing for stereo to match on its surface.
    pub fn plain(color: [f32; 3]) -> Self {
        Self { seed: 0, base_frequency: 0.0, spot_frequency: 0.0, palette: [color, color] }
    }

    /// Whether it is plain ([`Texture::plain`]).
    pub fn is_plain(&self) -> bool {
        self.base_frequency == 0.0 && self.spot_frequency == 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plain_texture_has_one_color_everywhere() {
        let texture = Texture::plain([0.2, 0.4, 0.6]);
        for p in [DVec3::ZERO, DVec3::new(0.37, -1.2, 4.0), DVec3::splat(13.1)] {
            assert_eq!(texture.albedo(p), [0.2, 0.4, 0.6]);
        }
    }

    fn texture() -> Texture {
        Texture { seed: 7, base_frequency: 3.0, spot_frequency: 4.0, palette: [[0.8, 0.3, 0.2], [0.2, 0.5, 0.8]] }
    }

    #[test]
    fn noise_is_continuous_and_bounded() {
        let t = texture();
        for i in 0..1000 {
            let p = DVec3::new(i as f64 * 0.013, 0.3, -0.7);
            let c = t.albedo(p);
            assert!(c.iter().all(|v| (0.0..=1.0).contains(v)));
        }
        let a = fbm3(DVec3::new(0.5, 0.5, 0.5), 1);
        let b = fbm3(DVec3::new(0.5 + 1e-6, 0.5, 0.5), 1);
        assert!((a[0] - b[0]).abs() < 1e-4);
    }

    #[test]
    fn texture_does_not_repeat_along_a_line() {
        // Compare windows of a long 1D slice against shifted copies: no shift up to 200 m
        // reproduces the first window.
        let t = texture();
        let sample = |x0: f64| -> Vec<[f32; 3]> { (0..64).map(|i| t.albedo(DVec3::new(x0 + i as f64 * 0.05, 0.1, 0.2))).collect() };
        let first = sample(0.0);
        for shift in 1..4000 {
            let other = sample(shift as f64 * 0.05);
            let diff: f32 = first.iter().zip(&other).map(|(a, b)| (a[0] - b[0]).abs() + (a[1] - b[1]).abs()).sum();
            assert!(diff > 0.5, "window repeats at shift {}", shift as f64 * 0.05);
        }
    }

    #[test]
    fn texture_has_contrast() {
        let t = texture();
        let values: Vec<f32> = (0..10_000)
            .map(|i| {
                let p = DVec3::new((i % 100) as f64 * 0.02, (i / 100) as f64 * 0.02, 0.0);
                t.albedo(p).iter().sum::<f32>() / 3.0
            })
            .collect();
        let mean = values.iter().sum::<f32>() / values.len() as f32;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / values.len() as f32;
        assert!(var.sqrt() > 0.08, "std {}", var.sqrt());
    }
}
