//! A virtual camera as a person moves it: world-space eye, target and up, and a vertical field
//! of view (the viewer page's form, as plain JS objects through serde), converted to and from
//! [`Camera`]s; and where an orbit around a camera pivots in a scene.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::camera::{Camera, Intrinsics, Rigid3};
use crate::scene::manifest::{Bounds, StartView};

/// A virtual camera as the page moves it: world-space eye, target and up, and a vertical field
/// of view. Image up is as close to `up` as the view direction allows.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LookAtView {
    /// Camera centre (world).
    pub eye: [f64; 3],
    /// A point the camera looks at (world).
    pub target: [f64; 3],
    /// World direction that appears up.
    pub up: [f64; 3],
    /// Vertical field of view in degrees.
    pub vertical_fov_deg: f64,
}

impl LookAtView {
    /// Checks that the view defines a camera: finite, eye apart from target, up not along the
    /// view direction, field of view in (0, 180).
    pub fn validate(&self) -> Result<(), String> {
        let all = self.eye.iter().chain(&self.target).chain(&self.up).chain(std::iter::once(&self.vertical_fov_deg));
        if all.clone().any(|v| !v.is_finite()) {
            return Err("view: non-finite eye, target, up or vertical_fov_deg".into());
        }
        let forward = DVec3::from(self.target) - DVec3::from(self.eye);
        if forward.length() < 1e-9 {
            return Err("view: eye and target coincide".into());
        }
        if forward.normalize().cross(DVec3::from(self.up)).length() < 1e-6 {
            return Err("view: up is parallel to the view direction".into());
        }
        if !(self.vertical_fov_deg > 0.1 && self.vertical_fov_deg < 179.0) {
            return Err(format!("view: vertical_fov_deg {} is not in (0.1, 179)", self.vertical_fov_deg));
        }
        Ok(())
    }

    /// The camera of this view for an image of `width_px x height_px` (centred principal
    /// point), each side within `1..=max_side_px`.
    pub fn camera(&self, width_px: u32, height_px: u32, max_side_px: u32) -> Result<Camera, String> {
        self.validate()?;
        if width_px == 0 || height_px == 0 || width_px > max_side_px || height_px > max_side_px {
            return Err(format!("render size {width_px}x{height_px} is not within 1..={max_side_px}"));
        }
        Ok(Camera {
            intrinsics: Intrinsics::from_vertical_fov(self.vertical_fov_deg.to_radians(), width_px, height_px),
            camera_from_world: Rigid3::camera_from_world_looking_at(self.eye.into(), self.target.into(), self.up.into()),
            width_px,
            height_px,
        })
    }

    /// The view of `camera`, its target `distance` ahead (the vertical field of view comes
    /// from `fy`; an off-centre principal point is not kept).
    pub fn of_camera(camera: &Camera, distance: f64) -> Self {
        let world_from_camera = camera.camera_from_world.inverse();
        let eye = world_from_camera.translation;
        let forward = world_from_camera.transform_vector(DVec3::Z);
        let up = world_from_camera.transform_vector(DVec3::NEG_Y);
        Self {
            eye: eye.into(),
            target: (eye + forward * distance).into(),
            up: up.into(),
            vertical_fov_deg: camera.intrinsics.vertical_fov_rad(camera.height_px).to_degrees(),
        }
    }

    /// The suggested first view of a scene (`start`), pivoting as [`pivot_distance`] says in a
    /// scene of `bounds`.
    pub fn of_start_view(start: &StartView, bounds: &Bounds) -> Self {
        let start_camera = Camera {
            intrinsics: Intrinsics::from_vertical_fov(start.vertical_fov_deg.to_radians(), 16, 9),
            camera_from_world: start.pose.camera_from_world(),
            width_px: 16,
            height_px: 9,
        };
        Self { vertical_fov_deg: start.vertical_fov_deg, ..Self::of_camera(&start_camera, pivot_distance(bounds, &start_camera)) }
    }
}

/// Distance from `camera`'s eye along its view to the centre of `bounds`, at least a tenth of
/// their diagonal: where an orbit around a snapped camera should pivot.
pub fn pivot_distance(bounds: &Bounds, camera: &Camera) -> f64 {
    let center = DVec3::from(bounds.center());
    let ahead = camera.camera_from_world.transform_point(center).z;
    ahead.max(0.1 * bounds.diagonal())
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAX_SIDE_PX: u32 = 16_384;

    fn view() -> LookAtView {
        LookAtView { eye: [1.0, -2.0, -5.0], target: [0.0, 0.5, 1.0], up: [0.0, 1.0, 0.0], vertical_fov_deg: 40.0 }
    }

    #[test]
    fn a_camera_and_its_view_convert_back_and_forth() {
        let camera = view().camera(320, 180, MAX_SIDE_PX).unwrap();
        let back = LookAtView::of_camera(&camera, 2.0);
        assert!((back.vertical_fov_deg - 40.0).abs() < 1e-9, "{back:?}");
        let again = back.camera(320, 180, MAX_SIDE_PX).unwrap();
        for (a, b) in
            camera.camera_from_world.rotation_rows().iter().flatten().zip(again.camera_from_world.rotation_rows().iter().flatten())
        {
            assert!((a - b).abs() < 1e-9, "{camera:?} against {again:?}");
        }
        assert!((camera.center_world() - again.center_world()).length() < 1e-9);
        // The target is `distance` ahead, on the line of sight (the image centre, pixel centres
        // at integers).
        let (pixel, depth_m) = camera.project_world(back.target.into()).unwrap();
        assert!((pixel.x - 159.5).abs() < 1e-6 && (pixel.y - 89.5).abs() < 1e-6 && (depth_m - 2.0).abs() < 1e-9, "{pixel:?} {depth_m}");
    }

    #[test]
    fn views_without_a_camera_are_refused_with_the_reason() {
        let cases = [
            (LookAtView { eye: [f64::NAN, 0.0, 0.0], ..view() }, "non-finite"),
            (LookAtView { target: view().eye, ..view() }, "coincide"),
            (LookAtView { up: [-1.0, 2.5, 6.0], ..view() }, "parallel"),
            (LookAtView { vertical_fov_deg: 180.0, ..view() }, "vertical_fov_deg"),
        ];
        for (bad, reason) in cases {
            let err = bad.camera(16, 9, MAX_SIDE_PX).unwrap_err();
            assert!(err.contains(reason), "{err}");
        }
        for (w, h) in [(0, 9), (16, 0), (MAX_SIDE_PX + 1, 9)] {
            assert!(view().camera(w, h, MAX_SIDE_PX).unwrap_err().contains("render size"));
        }
    }

    #[test]
    fn the_pivot_is_the_scene_centre_ahead_but_never_closer_than_a_tenth_of_the_diagonal() {
        let bounds = Bounds { min: [-1.0, -1.0, -1.0], max: [1.0, 1.0, 1.0] };
        let camera = view().camera(16, 9, MAX_SIDE_PX).unwrap();
        let ahead = camera.camera_from_world.transform_point(DVec3::ZERO).z;
        assert!((pivot_distance(&bounds, &camera) - ahead).abs() < 1e-12);
        let inside = LookAtView { eye: [0.0, 0.0, 0.0], target: [0.0, 0.0, 1.0], ..view() }.camera(16, 9, MAX_SIDE_PX).unwrap();
        assert!((pivot_distance(&bounds, &inside) - 0.1 * 12f64.sqrt()).abs() < 1e-12);
    }
}
