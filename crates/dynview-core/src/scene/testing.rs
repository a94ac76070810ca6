//! Small valid packages for tests.

use super::manifest::*;
use crate::camera::{Intrinsics, Rigid3};
use glam::DVec3;

/// A valid manifest with `cameras` cameras of 8x6 pixels on a small arc and `steps` steps.
pub fn small_manifest(cameras: usize, steps: u32) -> Manifest {
    let cameras = (0..cameras)
        .map(|i| {
            let angle = (i as f64 - 1.0) * 0.2;
            let eye = DVec3::new(4.0 * angle.sin(), 1.0, 4.0 * angle.cos());
            let pose = Rigid3::camera_from_world_looking_at(eye, DVec3::ZERO, DVec3::Y);
            CameraEntry {
                name: format!("cam{i}"),
                width: 8,
                height: 6,
                intrinsics: Intrinsics::from_vertical_fov(1.0, 8, 6),
                poses: vec![PoseEntry::from(pose); steps as usize],
                color_balance: None,
                plate: false,
            }
        })
        .collect::<Vec<_>>();
    let start = cameras.first().map(|c| c.poses[0]).unwrap_or(PoseEntry::from(Rigid3::IDENTITY));
    Manifest {
        format: FORMAT_NAME.into(),
        version: FORMAT_VERSION,
        name: "test".into(),
        fps: 25.0,
        time_step_count: steps,
        bounds: Bounds { min: [-2.0, -1.0, -2.0], max: [2.0, 2.0, 2.0] },
        cameras,
        clouds: CloudsEntry { file: "clouds.bin".into(), byte_length: 0 },
        frame_format: FrameFormat::Png,
        frames_index: None,
        start_view: StartView { time_step: 0, pose: start, vertical_fov_deg: 50.0 },
    }
}
