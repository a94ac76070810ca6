//! Z-buffered splatting: the sparse depth and color maps of a point cloud (nearest point per
//! pixel wins), and the previous output frame forward-warped into the current camera.

use super::transfer::PixelTransfer;
use crate::camera::Camera;
use crate::raster::{Raster, Rgb, RgbRaster, ScalarRaster, unit_from_u8};
use crate::scene::PointCloud;

/// Splatted depth and color with a coverage mask.
#[derive(Clone, Debug)]
pub struct SplatMaps {
    /// z-depth of the nearest sample per pixel; `f32::INFINITY` where none landed.
    pub depth: ScalarRaster,
    /// Color of that sample.
    pub color: RgbRaster,
    /// 1 where a sample landed, 0 elsewhere (`m(x)` of METHOD.md).
    pub mask: ScalarRaster,
}

impl SplatMaps {
    fn empty(width: usize, height: usize) -> Self {
        Self {
            depth: Raster::filled(width, height, f32::INFINITY),
            color: Raster::filled(width, height, [0.0; 3]),
            mask: Raster::filled(width, height, 0.0),
        }
    }

    #[inline]
    fn splat(&mut self, u: f32, v: f32, depth: f32, color: Rgb) {
        let (x, y) = (u.round(), v.round());
        if !(x >= 0.0 && y >= 0.0 && x < self.depth.width as f32 && y < self.depth.height as f32) {
            return;
        }
        let i = y as usize * self.depth.width + x as usize;
        if depth < self.depth.data[i] {
            self.depth.data[i] = depth;
            self.color.data[i] = color;
            self.mask.data[i] = 1.0;
        }
    }

    /// Number of covered pixels.
    pub fn covered(&self) -> usize {
        self.mask.data.iter().filter(|&&m| m > 0.0).count()
    }
}

/// Projects `cloud` into `camera` (`D^`, `I^` and `m` of METHOD.md).
pub fn project_cloud(cloud: &PointCloud, camera: &Camera) -> SplatMaps {
    let mut maps = SplatMaps::empty(camera.width_px as usize, camera.height_px as usize);
    let r = camera.camera_from_world.rotation;
    let t = camera.camera_from_world.translation;
    let k = camera.intrinsics;
    // f32 per point: precision far below a pixel for scenes of tens of metres.
    let rows: [[f32; 4]; 3] = std::array::from_fn(|i| {
        let row = r.row(i);
        [row.x as f32, row.y as f32, row.z as f32, t[i] as f32]
    });
    let (fx, fy, cx, cy) = (k.fx as f32, k.fy as f32, k.cx as f32, k.cy as f32);
    for (p, c) in cloud.positions_world.iter().zip(&cloud.colors) {
        let xc = rows[0][0] * p[0] + rows[0][1] * p[1] + rows[0][2] * p[2] + rows[0][3];
        let yc = rows[1][0] * p[0] + rows[1][1] * p[1] + rows[1][2] * p[2] + rows[1][3];
        let zc = rows[2][0] * p[0] + rows[2][1] * p[1] + rows[2][2] * p[2] + rows[2][3];
        if zc <= 1e-6 {
            continue;
        }
        let (u, v) = (fx * xc / zc + cx, fy * yc / zc + cy);
        maps.splat(u, v, zc, c.map(unit_from_u8));
    }
    maps
}

/// Forward-warps a rendered frame (its camera, depth and color) into `camera`: the
/// `D_{t-1}^{proj}` and `I_{t-1}^{proj}` of the temporal terms, with coverage as validity.
pub fn warp_frame(source: &Camera, depth: &ScalarRaster, color: &RgbRaster, camera: &Camera) -> SplatMaps {
    let mut maps = SplatMaps::empty(camera.width_px as usize, camera.height_px as usize);
    let transfer = PixelTransfer::new(source, camera);
    for y in 0..depth.height {
        for x in 0..depth.width {
            let d = depth.get(x, y);
            if !(d.is_finite() && d > 0.0) {
                continue;
            }
            if let Some((u, v, z)) = transfer.apply(x as f32, y as f32, d) {
                maps.splat(u, v, z, color.get(x, y));
            }
        }
    }
    maps
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Intrinsics, Rigid3};
    use glam::DVec3;

    fn camera() -> Camera {
        Camera {
            intrinsics: Intrinsics { fx: 10.0, fy: 10.0, cx: 4.5, cy: 3.5 },
            camera_from_world: Rigid3::IDENTITY,
            width_px: 10,
            height_px: 8,
        }
    }

    #[test]
    fn nearest_point_wins() {
        let cloud = PointCloud {
            positions_world: vec![[0.0, 0.0, 3.0], [0.0, 0.0, 2.0], [0.0, 0.0, 4.0], [0.0, 0.0, -1.0], [5.0, 0.0, 1.0]],
            colors: vec![[255, 0, 0], [0, 255, 0], [0, 0, 255], [9, 9, 9], [9, 9, 9]],
        };
        let maps = project_cloud(&cloud, &camera());
        // (0, 0, z) lands at the principal point, rounded to pixel (5, 4) (4.5 rounds up).
        let centre = maps.depth.get(5, 4);
        assert_eq!(centre, 2.0);
        assert_eq!(maps.color.get(5, 4), [0.0, 1.0, 0.0]);
        assert_eq!(maps.covered(), 1); // behind-camera and off-image points are dropped
    }

    #[test]
    fn frame_warp_to_itself_is_identity() {
        let cam = camera();
        let depth = ScalarRaster::filled(10, 8, 2.0);
        let color = RgbRaster::from_vec(10, 8, (0..80).map(|i| [i as f32 / 80.0, 0.0, 0.0]).collect()).unwrap();
        let maps = warp_frame(&cam, &depth, &color, &cam);
        assert_eq!(maps.covered(), 80);
        assert_eq!(maps.color, color);
        // Moving the camera back 1 m: everything is 1 m further away.
        let mut back = cam;
        back.camera_from_world.translation = DVec3::new(0.0, 0.0, 1.0);
        let maps = warp_frame(&cam, &depth, &color, &back);
        assert!(maps.depth.data.iter().filter(|d| d.is_finite()).all(|&d| (d - 3.0).abs() < 1e-5));
    }
}
