use super::*;
use dynview_core::{Intrinsics, Rigid3};

/// The static scene: a textured wall, the plane z = 5.
const WALL_Z_M: f64 = 5.0;
const SIZE_PX: (u32, u32) = (96, 64);
/// The mover's colour: far from any of the wall's.
const MOVER: [u8; 3] = [250, 10, 250];

fn wall_color(p: DVec3) -> [u8; 3] {
    let f = |v: f64| (255.0 * v).round() as u8;
    [f(0.5 + 0.4 * (4.0 * p.x).sin()), f(0.5 + 0.4 * (3.0 * p.y).cos()), 90]
}

/// The hand-held camera at step `k`: shaken a few centimetres and a little turned, looking
/// down +z at the wall.
fn camera(k: i64) -> Camera {
    let phase = k as f64 * 0.7;
    let eye = DVec3::new(0.04 * phase.sin(), 0.03 * phase.cos(), 0.0);
    let target = DVec3::new(0.1 * (phase * 0.5).sin(), 0.0, WALL_Z_M);
    Camera {
        intrinsics: Intrinsics { fx: 80.0, fy: 80.0, cx: 47.5, cy: 31.5 },
        camera_from_world: Rigid3::camera_from_world_looking_at(eye, target, DVec3::Y),
        width_px: SIZE_PX.0,
        height_px: SIZE_PX.1,
    }
}

/// Where the mover stands at step `k`: a square of the wall 1 m across, moving along x.
fn mover_at(k: i64, p: DVec3) -> bool {
    let centre_x = -1.5 + 0.25 * (k + 12) as f64;
    (p.x - centre_x).abs() < 0.5 && p.y.abs() < 0.5
}

/// The camera's frame at step `k`: the wall, with the mover painted on it.
fn frame(k: i64) -> RgbImage {
    let camera = camera(k);
    RgbImage::from_fn(SIZE_PX.0, SIZE_PX.1, |x, y| {
        let p = wall_point(&camera, x, y);
        image::Rgb(if mover_at(k, p) { MOVER } else { wall_color(p) })
    })
}

/// The point of the wall camera pixel `(x, y)` sees.
fn wall_point(camera: &Camera, x: u32, y: u32) -> DVec3 {
    let origin = camera.center_world();
    let far = camera.unproject_world(DVec2::new(f64::from(x), f64::from(y)), 1.0);
    let dir = far - origin;
    origin + dir * ((WALL_Z_M - origin.z) / dir.z)
}

/// The wall's z-depth in `camera` at every pixel.
fn wall_depth(camera: &Camera) -> ScalarRaster {
    let (w, h) = (SIZE_PX.0 as usize, SIZE_PX.1 as usize);
    let data = (0..w * h)
        .map(|i| {
            let p = wall_point(camera, (i % w) as u32, (i / w) as u32);
            camera.camera_from_world.transform_point(p).z as f32
        })
        .collect();
    ScalarRaster::from_vec(w, h, data).expect("one depth a pixel")
}

fn largest_difference(a: [u8; 3], b: [u8; 3]) -> u8 {
    (0..3).map(|i| a[i].abs_diff(b[i])).max().unwrap_or(0)
}

#[test]
fn the_mover_leaves_the_wall_behind_it_in_a_shaken_cameras_plate() {
    let target = camera(0);
    let own = frame(0);
    let others: Vec<(Camera, RgbImage)> = STEP_OFFSETS.iter().map(|&k| (camera(k), frame(k))).collect();
    let samples: Vec<PlateSample> = others.iter().map(|(camera, frame)| PlateSample { camera, frame }).collect();
    let plate = moving_plate(&target, &wall_depth(&target), &samples, &PlateOptions::default());
    let (mut mover_pixels, mut worst) = (0, 0u8);
    for (x, y, pixel) in own.enumerate_pixels() {
        let i = (y * SIZE_PX.0 + x) as usize;
        let truth = wall_color(wall_point(&target, x, y));
        if plate.confidence[i] == 0.0 {
            continue;
        }
        worst = worst.max(largest_difference(plate.image.get_pixel(x, y).0, truth));
        mover_pixels += usize::from(pixel.0 == MOVER);
    }
    let covered = plate.confidence.iter().filter(|&&c| c > 0.0).count();
    assert!(covered > (SIZE_PX.0 * SIZE_PX.1) as usize * 3 / 4, "{covered} pixels with a plate");
    assert!(mover_pixels > 200, "the mover hides {mover_pixels} pixels of the frame");
    // Bilinear samples of a smooth texture: a few levels off, never the mover's colour.
    assert!(worst <= 12, "the plate is {worst} levels off the wall");
}

#[test]
fn pixels_without_static_depth_or_samples_are_unknown() {
    let target = camera(0);
    let mut depth = wall_depth(&target);
    let w = SIZE_PX.0 as usize;
    depth.data[5 * w + 7] = f32::INFINITY;
    depth.data[6 * w + 7] = f32::NAN;
    let others: Vec<(Camera, RgbImage)> = STEP_OFFSETS[..MIN_SAMPLES - 1].iter().map(|&k| (camera(k), frame(k))).collect();
    let few: Vec<PlateSample> = others.iter().map(|(camera, frame)| PlateSample { camera, frame }).collect();
    let plate = moving_plate(&target, &depth, &few, &PlateOptions::default());
    assert!(plate.confidence.iter().all(|&c| c == 0.0), "fewer than {MIN_SAMPLES} frames saw every pixel");
    let others: Vec<(Camera, RgbImage)> = STEP_OFFSETS.iter().map(|&k| (camera(k), frame(k))).collect();
    let all: Vec<PlateSample> = others.iter().map(|(camera, frame)| PlateSample { camera, frame }).collect();
    let plate = moving_plate(&target, &depth, &all, &PlateOptions::default());
    assert_eq!(plate.confidence[5 * w + 7], 0.0);
    assert_eq!(plate.confidence[6 * w + 7], 0.0);
    assert!(plate.confidence[7 * w + 7] > 0.5, "{}", plate.confidence[7 * w + 7]);
}

#[test]
fn depth_range_is_the_median_and_95th_percentile_of_finite_depths() {
    let data: Vec<f32> = (1..=100).map(|d| d as f32).chain([f32::INFINITY, f32::NAN, 0.0]).collect();
    let n = data.len();
    let (median, far) = depth_range(&ScalarRaster::from_vec(n, 1, data).expect("raster")).expect("enough depths");
    assert_eq!((median, far), (51.0, 96.0));
    assert_eq!(depth_range(&ScalarRaster::filled(15, 1, 2.0)), None);
}
