//! Given a distortion, frames are undistorted back to the pinhole image.

use std::sync::atomic::AtomicBool;

use dynview_camera::Radial;
use dynview_core::Intrinsics;
use dynview_interchange::poses::{CameraPoses, FramePose};
use dynview_sfm::input::calibration::undistort_frames;
use dynview_sfm::input::frames::{CameraFrames, EventFrames};
use nalgebra::Vector2;

const W: u32 = 240;
const H: u32 = 160;

fn pattern(x: f64, y: f64) -> f64 {
    // Smooth stripes: bilinear resampling keeps them.
    128.0 + 100.0 * ((x / 9.0).sin() * (y / 7.0).cos())
}

fn mean_abs_diff(a: &image::RgbImage, b: &image::RgbImage) -> f64 {
    let (mut sum, mut n) = (0.0, 0.0);
    for y in 30..H - 30 {
        for x in 40..W - 40 {
            sum += (f64::from(a.get_pixel(x, y)[0]) - f64::from(b.get_pixel(x, y)[0])).abs();
            n += 1.0;
        }
    }
    sum / n
}

#[test]
fn a_given_distortion_is_removed() {
    let k = Radial { f: 200.0, cx: 119.5, cy: 79.5, k1: -0.25, k2: 0.05 };
    let pinhole = image::RgbImage::from_fn(W, H, |x, y| {
        let v = pattern(f64::from(x), f64::from(y)) as u8;
        image::Rgb([v, v, v])
    });
    // The distorted image a real lens would record: each pixel shows the pinhole point whose
    // distortion lands on it.
    let distorted = image::RgbImage::from_fn(W, H, |x, y| {
        let n = k.normalized(Vector2::new(f64::from(x), f64::from(y)));
        let v = pattern(k.f * n.x + k.cx, k.f * n.y + k.cy) as u8;
        image::Rgb([v, v, v])
    });
    let dir = tempfile::tempdir().unwrap();
    let source = dir.path().join("00000.png");
    distorted.save(&source).unwrap();
    let frames = EventFrames { cameras: vec![CameraFrames { name: "cam".into(), width: W, height: H, files: vec![source] }] };
    let calibration = CameraPoses {
        name: "cam".into(),
        width: W,
        height: H,
        intrinsics: Intrinsics { fx: k.f, fy: k.f, cx: k.cx, cy: k.cy },
        distortion: [k.k1, k.k2, 0.0, 0.0],
        frames: vec![FramePose { file: "00000.png".into(), camera_from_world: None }],
    };
    let out = undistort_frames(&frames, &[&calibration], &dir.path().join("undistorted"), &|_, _, _| {}, &AtomicBool::new(false)).unwrap();
    let undistorted = image::open(&out.cameras[0].files[0]).unwrap().to_rgb8();
    let (before, after) = (mean_abs_diff(&distorted, &pinhole), mean_abs_diff(&undistorted, &pinhole));
    println!("mean abs difference to the pinhole image: distorted {before:.2}, undistorted {after:.2}");
    assert!(after < 3.0 && after < 0.2 * before, "{after} vs {before}");
}
