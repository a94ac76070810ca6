//! Moving pixels between cameras: `(x, y, depth)` in one camera to pixel and depth in another,
//! as one 3x3 matrix and one vector precomputed per camera pair (f64 setup, f32 per pixel).

use glam::{DMat3, DVec3};

use crate::camera::Camera;

/// Maps pixels with z-depth of a source camera into a target camera:
/// `h = depth * M [x, y, 1] + e`, target pixel `(h.x / h.z, h.y / h.z)`, target depth `h.z`.
#[derive(Clone, Copy, Debug)]
pub struct PixelTransfer {
    m: [f32; 9],
    e: [f32; 3],
}

impl PixelTransfer {
    /// The transfer from `source` to `target`.
    pub fn new(source: &Camera, target: &Camera) -> Self {
        let k_s = source.intrinsics.matrix();
        let k_t = target.intrinsics.matrix();
        let r_rel: DMat3 = target.camera_from_world.rotation * source.camera_from_world.rotation.transpose();
        let t_rel: DVec3 = target.camera_from_world.translation - r_rel * source.camera_from_world.translation;
        let m = k_t * r_rel * k_s.inverse();
        let e = k_t * t_rel;
        // Row-major for the per-pixel dot products.
        let mt = m.transpose();
        let mut rows = [0.0f32; 9];
        for (i, v) in mt.to_cols_array().iter().enumerate() {
            rows[i] = *v as f32;
        }
        Self { m: rows, e: [e.x as f32, e.y as f32, e.z as f32] }
    }

    /// `M` (row-major) and `e`, for implementations elsewhere (the GPU path).
    pub fn coefficients(&self) -> ([f32; 9], [f32; 3]) {
        (self.m, self.e)
    }

    /// Target pixel and depth of source pixel `(x, y)` at depth `depth`; `None` when it lands
    /// at or behind the target camera.
    #[inline]
    pub fn apply(&self, x: f32, y: f32, depth: f32) -> Option<(f32, f32, f32)> {
        let m = &self.m;
        let hz = depth * (m[6] * x + m[7] * y + m[8]) + self.e[2];
        if hz.is_nan() || hz <= 1e-6 {
            return None;
        }
        let hx = depth * (m[0] * x + m[1] * y + m[2]) + self.e[0];
        let hy = depth * (m[3] * x + m[4] * y + m[5]) + self.e[1];
        let inv = 1.0 / hz;
        Some((hx * inv, hy * inv, hz))
    }
}

/// [`PixelTransfer`] with the row's `y` folded in: per pixel only the `x` terms remain.
#[derive(Clone, Copy, Debug)]
pub struct RowTransfer {
    mx: [f32; 3],
    base: [f32; 3],
    e: [f32; 3],
}

impl PixelTransfer {
    /// The transfer of pixels on row `y`.
    #[inline]
    pub fn row(&self, y: f32) -> RowTransfer {
        let m = &self.m;
        RowTransfer { mx: [m[0], m[3], m[6]], base: [m[1] * y + m[2], m[4] * y + m[5], m[7] * y + m[8]], e: self.e }
    }
}

impl RowTransfer {
    /// Target pixel and depth of source pixel `(x, y)` at `depth` (as [`PixelTransfer::apply`]).
    #[inline]
    pub fn apply(&self, x: f32, depth: f32) -> Option<(f32, f32, f32)> {
        let hz = depth * (self.mx[2] * x + self.base[2]) + self.e[2];
        if hz.is_nan() || hz <= 1e-6 {
            return None;
        }
        let inv = 1.0 / hz;
        let hx = depth * (self.mx[0] * x + self.base[0]) + self.e[0];
        let hy = depth * (self.mx[1] * x + self.base[1]) + self.e[1];
        Some((hx * inv, hy * inv, hz))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Intrinsics, Rigid3};
    use glam::{DVec2, DVec3};

    #[test]
    fn transfer_matches_unproject_then_project() {
        let a = Camera {
            intrinsics: Intrinsics::from_vertical_fov(0.8, 320, 180),
            camera_from_world: Rigid3::camera_from_world_looking_at(DVec3::new(1.0, 1.0, 5.0), DVec3::ZERO, DVec3::Y),
            width_px: 320,
            height_px: 180,
        };
        let b = Camera {
            intrinsics: Intrinsics::from_vertical_fov(0.9, 200, 100),
            camera_from_world: Rigid3::camera_from_world_looking_at(DVec3::new(-1.5, 0.5, 4.0), DVec3::ZERO, DVec3::Y),
            width_px: 200,
            height_px: 100,
        };
        let transfer = PixelTransfer::new(&a, &b);
        for &(x, y, d) in &[(10.0, 20.0, 3.0), (160.0, 90.0, 5.2), (300.5, 170.25, 7.0)] {
            let p = a.unproject_world(DVec2::new(x, y), d);
            let (px, depth) = b.project_world(p).unwrap();
            let (u, v, z) = transfer.apply(x as f32, y as f32, d as f32).unwrap();
            assert!((f64::from(u) - px.x).abs() < 1e-3 && (f64::from(v) - px.y).abs() < 1e-3 && (f64::from(z) - depth).abs() < 1e-4);
        }
        // The row form agrees.
        let (by_row, direct) = (transfer.row(20.0).apply(10.0, 3.0).unwrap(), transfer.apply(10.0, 20.0, 3.0).unwrap());
        assert!((by_row.0 - direct.0).abs() < 1e-3 && (by_row.1 - direct.1).abs() < 1e-3 && (by_row.2 - direct.2).abs() < 1e-5);
        // Identity transfer.
        let (u, v, z) = PixelTransfer::new(&a, &a).apply(12.0, 34.0, 2.0).unwrap();
        assert!((u - 12.0).abs() < 1e-4 && (v - 34.0).abs() < 1e-4 && (z - 2.0).abs() < 1e-5);
    }
}
