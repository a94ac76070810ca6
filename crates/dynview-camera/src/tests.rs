//! Round trips, Jacobians against central differences and COLMAP parameter orders.

use super::*;

/// Normalized points spread over a wide-angle image (up to about 35 degrees off axis).
const POINTS: [[f64; 2]; 6] = [[0.0, 0.0], [0.3, -0.2], [-0.5, 0.4], [0.7, 0.1], [-0.05, -0.6], [1e-9, 2e-9]];

fn close(a: [f64; 2], b: [f64; 2], tolerance: f64) -> bool {
    (a[0] - b[0]).abs() <= tolerance && (a[1] - b[1]).abs() <= tolerance
}

fn cameras() -> Vec<Camera> {
    vec![
        Camera::SimplePinhole(SimplePinhole { f: 800.0, cx: 320.0, cy: 240.0 }),
        Camera::Pinhole(Pinhole { fx: 800.0, fy: 780.0, cx: 320.0, cy: 240.0 }),
        Camera::SimpleRadial(SimpleRadial { f: 800.0, cx: 320.0, cy: 240.0, k: -0.12 }),
        Camera::Radial(Radial { f: 800.0, cx: 320.0, cy: 240.0, k1: -0.1, k2: 0.02 }),
        Camera::OpenCv(OpenCv {
            pinhole: Pinhole { fx: 800.0, fy: 780.0, cx: 320.0, cy: 240.0 },
            distortion: OpenCvDistortion { k1: -0.1, k2: 0.02, p1: 1e-3, p2: -2e-3 },
        }),
    ]
}

#[test]
fn distortion_and_pixels_round_trip() {
    for camera in cameras() {
        for normalized in POINTS {
            let distorted = camera.distort(normalized);
            assert!(close(camera.undistort(distorted), normalized, 1e-12), "{camera:?} {normalized:?}");
            let pixel = camera.pixel_from_normalized(normalized);
            assert!(close(camera.normalized_from_pixel(pixel), normalized, 1e-12), "{camera:?} {normalized:?}");
            // The pixel is the pinhole pixel of the distorted point.
            let pinhole = camera.to_opencv().pinhole;
            assert!(close(pinhole.pixel_from_normalized(distorted), pixel, 1e-9), "{camera:?} {normalized:?}");
            // Every model is a special case of OpenCV's.
            assert!(close(camera.to_opencv().pixel_from_normalized(normalized), pixel, 1e-9), "{camera:?}");
        }
    }
}

#[test]
fn params_round_trip_and_have_the_models_counts() {
    for camera in cameras() {
        let params = camera.params();
        assert_eq!(params.len(), camera.model().param_count());
        assert_eq!(Camera::from_params(camera.model(), &params), Some(camera));
        assert_eq!(Camera::from_params(camera.model(), &params[1..]), None);
        assert_eq!(pixel_from_normalized(camera.model(), &[], [0.0, 0.0]), None);
    }
}

#[test]
fn colmap_names_ids_and_counts() {
    let expected = [("SIMPLE_PINHOLE", 0, 3), ("PINHOLE", 1, 4), ("SIMPLE_RADIAL", 2, 4), ("RADIAL", 3, 5), ("OPENCV", 4, 8)];
    for (model, (name, id, count)) in CameraModel::ALL.into_iter().zip(expected) {
        assert_eq!((model.name(), model.id(), model.param_count()), (name, id, count));
        assert_eq!(CameraModel::from_name(name), Some(model));
        assert_eq!(CameraModel::from_id(id), Some(model));
    }
    assert_eq!(CameraModel::from_name("FULL_OPENCV"), None);
    assert_eq!(CameraModel::from_id(5), None);
}

/// Pixels of the normalized point `(0.5, -0.25)` worked out by hand from COLMAP's formulas
/// (`r2 = 0.3125`, `r4 = 0.09765625`, `x y = -0.125`), one per model and parameter order.
#[test]
fn colmap_parameter_orders_against_hand_checked_pixels() {
    let normalized = [0.5, -0.25];
    let cases: [(CameraModel, &[f64], [f64; 2]); 5] = [
        // u = 100 * 0.5 + 50, v = 100 * -0.25 + 40.
        (CameraModel::SimplePinhole, &[100.0, 50.0, 40.0], [100.0, 15.0]),
        // fy = 200: v = 200 * -0.25 + 40.
        (CameraModel::Pinhole, &[100.0, 200.0, 50.0, 40.0], [100.0, -10.0]),
        // d = 1 + 0.1 r2 = 1.03125.
        (CameraModel::SimpleRadial, &[100.0, 50.0, 40.0, 0.1], [101.5625, 14.21875]),
        // d = 1 + 0.1 r2 + 0.2 r4 = 1.05078125.
        (CameraModel::Radial, &[100.0, 50.0, 40.0, 0.1, 0.2], [102.5390625, 13.73046875]),
        // radial = 0.05078125; x' = 0.5 + 0.025390625 - 0.0025 + 0.01625 = 0.539140625,
        // y' = -0.25 - 0.0126953125 - 0.005 + 0.004375 = -0.2633203125.
        (CameraModel::OpenCv, &[100.0, 200.0, 50.0, 40.0, 0.1, 0.2, 0.01, 0.02], [103.9140625, -12.6640625]),
    ];
    for (model, params, expected) in cases {
        let pixel = pixel_from_normalized(model, params, normalized).expect("params match the model");
        assert!(close(pixel, expected, 1e-12), "{model}: {pixel:?}, expected {expected:?}");
        let back = normalized_from_pixel(model, params, pixel).expect("params match the model");
        assert!(close(back, normalized, 1e-12), "{model}: {back:?}");
    }
}

#[test]
fn radial_jacobians_match_central_differences() {
    const STEP: f64 = 1e-6;
    let radial = Radial { f: 700.0, cx: 320.0, cy: 240.0, k1: -0.2, k2: 0.05 };
    for normalized in POINTS {
        let d_normalized = radial.d_pixel_d_normalized(normalized);
        for axis in 0..2 {
            let (mut plus, mut minus) = (normalized, normalized);
            plus[axis] += STEP;
            minus[axis] -= STEP;
            let (a, b) = (radial.pixel_from_normalized(plus), radial.pixel_from_normalized(minus));
            for row in 0..2 {
                let numeric = (a[row] - b[row]) / (2.0 * STEP);
                assert!((numeric - d_normalized[row][axis]).abs() < 1e-5, "{normalized:?} d{row}/dn{axis}: {numeric} vs {d_normalized:?}");
            }
        }
        let d_params = radial.d_pixel_d_params(normalized);
        let params = radial.params();
        for index in 0..radial::PARAM_COUNT {
            let step = STEP * params[index].abs().max(1.0);
            let (mut plus, mut minus) = (params.clone(), params.clone());
            plus[index] += step;
            minus[index] -= step;
            let pixel = |p: &[f64]| Radial::from_params(p).expect("five").pixel_from_normalized(normalized);
            let (a, b) = (pixel(&plus), pixel(&minus));
            for row in 0..2 {
                let numeric = (a[row] - b[row]) / (2.0 * step);
                assert!((numeric - d_params[row][index]).abs() < 1e-5, "{normalized:?} d{row}/dp{index}: {numeric} vs {d_params:?}");
            }
        }
    }
}

#[test]
fn pinhole_projects_and_lifts_with_z_depth() {
    let pinhole = Pinhole { fx: 500.0, fy: 510.0, cx: 319.5, cy: 239.5 };
    let point = [0.4, -0.3, 2.0];
    let pixel = pinhole.pixel_from_camera(point).expect("in front");
    assert!(close(pixel, [500.0 * 0.2 + 319.5, 510.0 * -0.15 + 239.5], 1e-12));
    let back = pinhole.camera_from_pixel(pixel, 2.0);
    assert!((0..3).all(|i| (back[i] - point[i]).abs() < 1e-12), "{back:?}");
    assert_eq!(pinhole.pixel_from_camera([0.0, 0.0, 0.0]), None);
    assert_eq!(pinhole.pixel_from_camera([0.0, 0.0, -1.0]), None);
}

/// The stored form of `Radial` is the one `dynview-sfm`'s work files have always had, so that
/// their keys still match; `Rigid3` stores its rotation (column-major) and translation.
#[cfg(feature = "serde")]
#[test]
fn radial_and_rigid_serialize_as_dynview_sfm_stores_them() {
    let k = Radial { f: 500.0, cx: 319.5, cy: 239.5, k1: -0.1, k2: 0.01 };
    let json = serde_json::to_string(&k).expect("serializes");
    assert_eq!(json, r#"{"focal_px":500.0,"cx_px":319.5,"cy_px":239.5,"k1":-0.1,"k2":0.01}"#);
    assert_eq!(serde_json::from_str::<Radial>(&json).expect("reads back"), k);
    let pose = Rigid3::new(glam::DMat3::from_rotation_z(0.5), glam::DVec3::new(1.0, -2.0, 3.0));
    let json = serde_json::to_string(&pose).expect("serializes");
    assert!(json.starts_with(r#"{"rotation":["#) && json.ends_with(r#""translation":[1.0,-2.0,3.0]}"#), "{json}");
    assert_eq!(serde_json::from_str::<Rigid3>(&json).expect("reads back"), pose);
}
