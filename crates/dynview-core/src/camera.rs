//! The pinhole camera model and posed cameras (OpenCV convention). The pinhole maths is
//! [`dynview_camera::Pinhole`]'s; [`Intrinsics`] is the same model with glam types and serde.
//! Poses are [`Rigid3`] (`dynview_camera::Rigid3`, re-exported here).
//!
//! Axes: x right, y down, z forward (into the scene). A world point maps into the camera as
//! `X_c = R X_w + t` (`camera_from_world`); the camera centre is `C = -R^T t`. Pixel centres
//! sit at integer coordinates, so the top-left pixel's centre is `(0, 0)` and a `W x H` image
//! spans `[-0.5, W - 0.5] x [-0.5, H - 0.5]`. Depth is z-depth in the camera, not ray length.

use dynview_camera::Pinhole;
pub use dynview_camera::Rigid3;
use glam::{DMat3, DVec2, DVec3};
use serde::{Deserialize, Serialize};

/// Pinhole intrinsics in pixels. Parameter order follows COLMAP's `PINHOLE` model:
/// `fx, fy, cx, cy`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Focal length along x, in pixels.
    pub fx: f64,
    /// Focal length along y, in pixels.
    pub fy: f64,
    /// Principal point x, in pixels (pixel centres at integers).
    pub cx: f64,
    /// Principal point y, in pixels (pixel centres at integers).
    pub cy: f64,
}

impl Intrinsics {
    /// Intrinsics of a camera with the principal point at the image centre and the given
    /// vertical field of view.
    pub fn from_vertical_fov(vertical_fov_rad: f64, width_px: u32, height_px: u32) -> Self {
        let f = 0.5 * f64::from(height_px) / (0.5 * vertical_fov_rad).tan();
        Self { fx: f, fy: f, cx: 0.5 * f64::from(width_px) - 0.5, cy: 0.5 * f64::from(height_px) - 0.5 }
    }

    /// Vertical field of view in radians for an image `height_px` tall.
    pub fn vertical_fov_rad(&self, height_px: u32) -> f64 {
        2.0 * (0.5 * f64::from(height_px) / self.fy).atan()
    }

    /// The same camera for an image scaled by `scale` in both directions (e.g. 0.5 for half
    /// resolution). Pixel centres stay at integers at the new resolution.
    pub fn scaled(&self, scale: f64) -> Self {
        Self { fx: self.fx * scale, fy: self.fy * scale, cx: (self.cx + 0.5) * scale - 0.5, cy: (self.cy + 0.5) * scale - 0.5 }
    }

    /// Projects a point in camera coordinates to pixel coordinates. Returns `None` for points
    /// at or behind the camera plane (`z <= 0`).
    #[inline]
    pub fn project(&self, point_camera: DVec3) -> Option<DVec2> {
        Pinhole::from(*self).pixel_from_camera(point_camera.to_array()).map(DVec2::from_array)
    }

    /// Lifts a pixel with z-depth `depth_m` back to camera coordinates.
    #[inline]
    pub fn unproject(&self, pixel: DVec2, depth_m: f64) -> DVec3 {
        DVec3::from_array(Pinhole::from(*self).camera_from_pixel(pixel.to_array(), depth_m))
    }

    /// The 3x3 calibration matrix `K` (column-major, as glam stores it).
    pub fn matrix(&self) -> DMat3 {
        DMat3::from_cols(DVec3::new(self.fx, 0.0, 0.0), DVec3::new(0.0, self.fy, 0.0), DVec3::new(self.cx, self.cy, 1.0))
    }

    /// True when every parameter is finite and the focal lengths are positive.
    pub fn is_valid(&self) -> bool {
        [self.fx, self.fy, self.cx, self.cy].iter().all(|v| v.is_finite()) && self.fx > 0.0 && self.fy > 0.0
    }
}

impl From<Intrinsics> for Pinhole {
    #[inline]
    fn from(k: Intrinsics) -> Self {
        Self { fx: k.fx, fy: k.fy, cx: k.cx, cy: k.cy }
    }
}

impl From<Pinhole> for Intrinsics {
    #[inline]
    fn from(k: Pinhole) -> Self {
        Self { fx: k.fx, fy: k.fy, cx: k.cx, cy: k.cy }
    }
}

/// A posed pinhole camera with an image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Intrinsics at `width_px x height_px`.
    pub intrinsics: Intrinsics,
    /// World-to-camera transform.
    pub camera_from_world: Rigid3,
    /// Image width in pixels.
    pub width_px: u32,
    /// Image height in pixels.
    pub height_px: u32,
}

impl Camera {
    /// Projects a world point to `(pixel, depth_m)`; `None` when behind the camera.
    pub fn project_world(&self, point_world: DVec3) -> Option<(DVec2, f64)> {
        let p = self.camera_from_world.transform_point(point_world);
        self.intrinsics.project(p).map(|px| (px, p.z))
    }

    /// The world point seen at `pixel` with z-depth `depth_m`.
    pub fn unproject_world(&self, pixel: DVec2, depth_m: f64) -> DVec3 {
        let p_camera = self.intrinsics.unproject(pixel, depth_m);
        self.camera_from_world.inverse().transform_point(p_camera)
    }

    /// The camera centre in world coordinates.
    pub fn center_world(&self) -> DVec3 {
        self.camera_from_world.camera_center_world()
    }

    /// True when `pixel` lies inside the image (pixel centres at integers).
    pub fn contains(&self, pixel: DVec2) -> bool {
        pixel.x >= -0.5 && pixel.y >= -0.5 && pixel.x < f64::from(self.width_px) - 0.5 && pixel.y < f64::from(self.height_px) - 0.5
    }

    /// The same camera rendered at another resolution (intrinsics scaled per axis).
    pub fn resized(&self, width_px: u32, height_px: u32) -> Self {
        let sx = f64::from(width_px) / f64::from(self.width_px);
        let sy = f64::from(height_px) / f64::from(self.height_px);
        Self {
            intrinsics: Intrinsics {
                fx: self.intrinsics.fx * sx,
                fy: self.intrinsics.fy * sy,
                cx: (self.intrinsics.cx + 0.5) * sx - 0.5,
                cy: (self.intrinsics.cy + 0.5) * sy - 0.5,
            },
            width_px,
            height_px,
            ..*self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn approx(a: DVec3, b: DVec3, tol: f64) -> bool {
        (a - b).abs().max_element() <= tol
    }

    #[test]
    fn project_hand_checked() {
        let k = Intrinsics { fx: 500.0, fy: 400.0, cx: 320.0, cy: 240.0 };
        // (1, -0.5, 2): x = 500 * 0.5 + 320 = 570, y = 400 * -0.25 + 240 = 140.
        let px = k.project(DVec3::new(1.0, -0.5, 2.0)).unwrap();
        assert_eq!(px, DVec2::new(570.0, 140.0));
        assert!(k.project(DVec3::new(0.0, 0.0, 0.0)).is_none());
        assert!(k.project(DVec3::new(0.0, 0.0, -1.0)).is_none());
    }

    #[test]
    fn unproject_inverts_project() {
        let k = Intrinsics { fx: 812.5, fy: 799.0, cx: 479.5, cy: 269.5 };
        let p = DVec3::new(-0.7, 0.3, 4.25);
        let px = k.project(p).unwrap();
        assert!(approx(k.unproject(px, p.z), p, 1e-12));
    }

    #[test]
    fn fov_round_trip_and_centre() {
        let k = Intrinsics::from_vertical_fov(60f64.to_radians(), 960, 540);
        // f = 270 / tan(30 deg) = 467.65...
        assert!((k.fy - 270.0 / (30f64.to_radians()).tan()).abs() < 1e-9);
        assert_eq!((k.cx, k.cy), (479.5, 269.5));
        assert!((k.vertical_fov_rad(540) - 60f64.to_radians()).abs() < 1e-12);
    }

    #[test]
    fn scaled_keeps_pixel_centre_convention() {
        let k = Intrinsics::from_vertical_fov(1.0, 64, 32);
        let half = k.scaled(0.5);
        // Centre of a 64-wide image is 31.5; of a 32-wide image 15.5.
        assert_eq!(half.cx, 15.5);
        assert_eq!(half.cy, 7.5);
        assert_eq!(half.fx, k.fx * 0.5);
    }

    #[test]
    fn camera_world_round_trip_and_resize() {
        let cam = Camera {
            intrinsics: Intrinsics::from_vertical_fov(0.9, 96, 54),
            camera_from_world: Rigid3::camera_from_world_looking_at(DVec3::new(0.0, 1.0, 5.0), DVec3::ZERO, DVec3::Y),
            width_px: 96,
            height_px: 54,
        };
        let p = DVec3::new(0.3, 0.2, -0.4);
        let (px, depth) = cam.project_world(p).unwrap();
        assert!(cam.contains(px));
        assert!(approx(cam.unproject_world(px, depth), p, 1e-12));
        let small = cam.resized(48, 27);
        let (px_small, _) = small.project_world(p).unwrap();
        assert!(((px_small.x + 0.5) * 2.0 - (px.x + 0.5)).abs() < 1e-9);
    }
}
