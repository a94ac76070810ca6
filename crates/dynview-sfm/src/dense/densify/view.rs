//! A view at the working resolution: grayscale `f32` and RGB pixels, scaled intrinsics, and
//! the pose's rotation and centre as nalgebra values (computed once: every pixel is projected
//! and lifted through them).

use dynview_camera::PoseMatrices;
use nalgebra::{Vector2, Vector3};
use opencv::core::{Mat, Size};
use opencv::prelude::*;

use crate::error::{SfmError, SfmResult};
use crate::mapping::points::TimestepView;

/// One view, reduced for matching.
pub(super) struct WorkView {
    /// Width (px).
    pub width: usize,
    /// Height (px).
    pub height: usize,
    /// Luma in `[0, 1]`, row-major.
    pub gray: Vec<f32>,
    /// sRGB, row-major.
    pub rgb: Vec<[u8; 3]>,
    /// Focal length (px) at this resolution.
    pub focal_px: f64,
    /// Principal point x (px) at this resolution.
    pub cx_px: f64,
    /// Principal point y (px) at this resolution.
    pub cy_px: f64,
    /// The pose (`camera_from_world`) as its rotation and centre.
    pub pose: PoseMatrices,
}

impl WorkView {
    /// The view reduced so that its longest side is at most `max_side_px`; `None` when its frame
    /// is empty or not 8-bit BGR, or its calibration is not finite.
    pub fn from_view(view: &TimestepView, max_side_px: usize) -> SfmResult<Option<Self>> {
        let image = view.image_bgr;
        let k = &view.intrinsics;
        let finite = [k.f, k.cx, k.cy].iter().all(|v| v.is_finite()) && k.f > 0.0;
        let pose = view.pose.matrices();
        let pose_finite = pose.rotation.iter().chain(pose.center_world.iter()).all(|v| v.is_finite());
        if image.empty() || image.typ() != opencv::core::CV_8UC3 || !finite || !pose_finite {
            return Ok(None);
        }
        let (width, height) = (image.cols() as usize, image.rows() as usize);
        let scale = (max_side_px.max(8) as f64 / width.max(height) as f64).min(1.0);
        let (new_width, new_height) = (((width as f64 * scale).round() as usize).max(1), ((height as f64 * scale).round() as usize).max(1));
        let mut small = Mat::default();
        let source = if (new_width, new_height) == (width, height) {
            image
        } else {
            let size = Size::new(new_width as i32, new_height as i32);
            opencv::imgproc::resize(image, &mut small, size, 0.0, 0.0, opencv::imgproc::INTER_AREA)
                .map_err(SfmError::cv("densify: resize"))?;
            &small
        };
        let continuous;
        let source = if source.is_continuous() {
            source
        } else {
            continuous = source.try_clone().map_err(SfmError::cv("densify: copy"))?;
            &continuous
        };
        let bytes = source.data_bytes().map_err(SfmError::cv("densify: pixels"))?;
        let rgb: Vec<[u8; 3]> = bytes.chunks_exact(3).map(|p| [p[2], p[1], p[0]]).collect();
        let gray = rgb.iter().map(|p| (0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2])) / 255.0).collect();
        let (sx, sy) = (new_width as f64 / width as f64, new_height as f64 / height as f64);
        Ok(Some(Self {
            width: new_width,
            height: new_height,
            gray,
            rgb,
            focal_px: k.f * 0.5 * (sx + sy),
            cx_px: (k.cx + 0.5) * sx - 0.5,
            cy_px: (k.cy + 0.5) * sy - 0.5,
            pose,
        }))
    }

    /// Direction (camera frame, `z = 1`) of the ray through pixel `(x, y)`.
    pub fn ray_camera(&self, x: f64, y: f64) -> Vector3<f64> {
        Vector3::new((x - self.cx_px) / self.focal_px, (y - self.cy_px) / self.focal_px, 1.0)
    }

    /// Pixel and depth (m, camera z) of a world point in front of the camera.
    pub fn project(&self, point_world: &Vector3<f64>) -> Option<(Vector2<f64>, f64)> {
        let p = self.pose.point_camera(point_world);
        (p.z > 1e-9 && p.iter().all(|v| v.is_finite()))
            .then(|| (Vector2::new(self.focal_px * p.x / p.z + self.cx_px, self.focal_px * p.y / p.z + self.cy_px), p.z))
    }

    /// The nearest pixel's index of a pixel position inside the image.
    pub fn index_of(&self, pixel: &Vector2<f64>) -> Option<usize> {
        let (x, y) = (pixel.x.round(), pixel.y.round());
        (x >= 0.0 && y >= 0.0 && x < self.width as f64 && y < self.height as f64).then(|| y as usize * self.width + x as usize)
    }

    /// World point at `depth_m` along the ray through `(x, y)`.
    pub fn world_at(&self, x: f64, y: f64, depth_m: f64) -> Vector3<f64> {
        self.pose.rotation.transpose() * (self.ray_camera(x, y) * depth_m) + self.pose.center_world
    }

    /// Optical axis in the world.
    pub fn axis_world(&self) -> Vector3<f64> {
        self.pose.rotation.row(2).transpose()
    }
}
