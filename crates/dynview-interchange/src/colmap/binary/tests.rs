//! The binary form: layout, round trips and hostile input.

use super::*;
use crate::colmap::tests::sample_model;

fn all_files(m: &ColmapModel) -> [(Vec<u8>, &'static str); 3] {
    [(m.cameras_bin(), "cameras.bin"), (m.images_bin(), "images.bin"), (m.points3d_bin(), "points3D.bin")]
}

fn parse(bytes: &[u8], file: &str) -> Result<(), ColmapError> {
    match file {
        "cameras.bin" => parse_cameras_bin(bytes, file).map(drop),
        "images.bin" => parse_images_bin(bytes, file).map(drop),
        _ => parse_points3d_bin(bytes, file).map(drop),
    }
}

#[test]
fn binary_round_trip_is_exact() {
    let m = sample_model();
    let back = ColmapModel::from_binary(&m.cameras_bin(), &m.images_bin(), &m.points3d_bin()).unwrap();
    assert_eq!(back.cameras, m.cameras);
    assert_eq!(back.points3d, m.points3d);
    for (id, im) in &m.images {
        let b = &back.images[id];
        assert_eq!((b.name.as_str(), b.camera_id, &b.points2d), (im.name.as_str(), im.camera_id, &im.points2d));
        assert_eq!(b.camera_from_world.translation, im.camera_from_world.translation);
        let d = b.camera_from_world.rotation - im.camera_from_world.rotation;
        assert!(d.to_cols_array().iter().all(|v| v.abs() < 1e-15));
    }
}

#[test]
fn binary_layout_hand_checked() {
    let mut m = ColmapModel::default();
    m.cameras.insert(7, ColmapCamera { model: CameraModel::Pinhole, width: 640, height: 480, params: vec![500.0, 510.0, 320.0, 240.0] });
    m.images.insert(
        3,
        ColmapImage {
            camera_id: 7,
            camera_from_world: Rigid3::new(glam::DMat3::IDENTITY, glam::DVec3::new(1.0, 2.0, 3.0)),
            name: "c/a.png".into(),
            points2d: vec![Point2D { xy: [1.5, 2.5], point3d_id: None }],
        },
    );
    let cameras = m.cameras_bin();
    assert_eq!(cameras.len(), 8 + 4 + 4 + 8 + 8 + 4 * 8);
    assert_eq!(&cameras[..8], &1u64.to_le_bytes());
    assert_eq!(&cameras[8..12], &7u32.to_le_bytes());
    assert_eq!(&cameras[12..16], &1i32.to_le_bytes()); // PINHOLE
    assert_eq!(&cameras[16..24], &640u64.to_le_bytes());
    assert_eq!(&cameras[32..40], &500f64.to_le_bytes());
    let images = m.images_bin();
    assert_eq!(images.len(), 8 + 4 + 7 * 8 + 4 + 8 + 8 + 24);
    assert_eq!(&images[12..20], &1f64.to_le_bytes()); // qw of the identity
    assert_eq!(&images[44..52], &1f64.to_le_bytes()); // tx
    assert_eq!(&images[68..72], &7u32.to_le_bytes());
    assert_eq!(&images[72..80], b"c/a.png\0");
    assert_eq!(&images[80..88], &1u64.to_le_bytes());
    assert_eq!(&images[104..112], &u64::MAX.to_le_bytes());
    assert_eq!(ColmapModel::default().points3d_bin(), 0u64.to_le_bytes());
}

#[test]
fn every_truncation_is_an_error_naming_the_file() {
    for (bytes, file) in all_files(&sample_model()) {
        for len in 0..bytes.len() {
            let err = parse(&bytes[..len], file).unwrap_err().to_string();
            assert!(err.starts_with(file), "{file} cut at {len}: {err}");
        }
        parse(&bytes, file).unwrap();
        let mut longer = bytes.clone();
        longer.push(0);
        let err = parse(&longer, file).unwrap_err().to_string();
        assert!(err.contains("1 bytes left"), "{err}");
    }
}

#[test]
fn corrupt_bytes_never_panic() {
    // Every byte set to a few hostile values, one at a time: errors or a model, no panic.
    for (bytes, file) in all_files(&sample_model()) {
        for i in 0..bytes.len() {
            for value in [0x00, 0x7f, 0xff] {
                let mut bad = bytes.clone();
                bad[i] = value;
                let _ = parse(&bad, file);
            }
        }
    }
}

fn expect(bytes: &[u8], file: &str, wanted: &[&str]) {
    let err = parse(bytes, file).unwrap_err().to_string();
    for w in wanted {
        assert!(err.contains(w), "expected {w:?} in: {err}");
    }
}

#[test]
fn hostile_counts_and_fields_are_named() {
    let m = sample_model();
    let [(cameras, _), (images, _), (points, _)] = all_files(&m);
    // Counts far beyond the file: refused before allocating.
    expect(&u64::MAX.to_le_bytes(), "cameras.bin", &["cameras.bin: header: field `num_cameras`", "cannot fit"]);
    let mut bad = images.clone();
    bad[..8].copy_from_slice(&(1u64 << 40).to_le_bytes());
    expect(&bad, "images.bin", &["field `num_reg_images`"]);
    // The first image (id 1) of the sample: name at 8 + 4 + 56 + 4 = 72, "cam0/00000.png\0".
    let points_at = 72 + "cam0/00000.png".len() + 1;
    let mut bad = images.clone();
    bad[points_at..points_at + 8].copy_from_slice(&u64::MAX.to_le_bytes());
    expect(&bad, "images.bin", &["images.bin: image 0 (id 1): field `num_points2D`"]);
    let mut bad = images.clone();
    bad[76] = b' ';
    expect(&bad, "images.bin", &["image 0 (id 1): field `name`", "whitespace"]);
    let mut bad = images.clone();
    bad[72..].fill(b'a');
    expect(&bad, "images.bin", &["field `name`", "not NUL-terminated"]);
    let mut long = bad[..72].to_vec();
    long.extend(vec![b'a'; MAX_IMAGE_NAME_BYTES + 100]);
    expect(&long, "images.bin", &["field `name`", "no NUL within 4096 bytes"]);
    let mut bad = images.clone();
    bad[44..52].copy_from_slice(&f64::NAN.to_le_bytes());
    expect(&bad, "images.bin", &["field `tvec[0]`"]);
    let mut bad = images;
    bad[12..44].fill(0);
    expect(&bad, "images.bin", &["field `qvec`", "zero quaternion"]);
    let mut bad = cameras.clone();
    bad[12..16].copy_from_slice(&5i32.to_le_bytes());
    expect(&bad, "cameras.bin", &["camera 0 (id 1): field `model_id`", "unsupported camera model 5"]);
    let mut bad = cameras;
    bad[16..24].copy_from_slice(&(1u64 << 33).to_le_bytes());
    expect(&bad, "cameras.bin", &["field `width`"]);
    // Track length of the first point: after id, xyz, rgb, error.
    let mut bad = points;
    let at = 8 + 8 + 24 + 3 + 8;
    bad[at..at + 8].copy_from_slice(&(u64::MAX / 2).to_le_bytes());
    expect(&bad, "points3D.bin", &["point3D 0 (id 7): field `track_length`"]);
    // Duplicate ids: two PINHOLE cameras, the second renumbered to the first's id.
    let mut two = ColmapModel::default();
    two.cameras.insert(1, m.cameras[&1].clone());
    two.cameras.insert(2, m.cameras[&1].clone());
    let mut bytes = two.cameras_bin();
    let second_id_at = 8 + MIN_CAMERA_BYTES + 8;
    bytes[second_id_at..second_id_at + 4].copy_from_slice(&1u32.to_le_bytes());
    expect(&bytes, "cameras.bin", &["camera 1 (id 1): field `camera_id`", "duplicate id 1"]);
}
