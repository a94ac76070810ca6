//! Tests across the two forms: the shared fixture, model folders, and interoperation with a
//! real COLMAP when one is installed.

use std::path::Path;
use std::process::Command;

use glam::{DMat3, DVec3};

use super::*;
use dynview_core::camera::{Intrinsics, Rigid3};

/// A small model using every supported camera model, with points and tracks.
pub(crate) fn sample_model() -> ColmapModel {
    let mut m = ColmapModel::default();
    let k = Intrinsics { fx: 500.0, fy: 510.0, cx: 319.5, cy: 239.5 };
    m.cameras.insert(1, ColmapCamera::pinhole(&k, 640, 480));
    m.cameras.insert(2, ColmapCamera { model: CameraModel::SimplePinhole, width: 320, height: 240, params: vec![250.0, 160.0, 120.0] });
    m.cameras
        .insert(3, ColmapCamera { model: CameraModel::SimpleRadial, width: 320, height: 240, params: vec![251.0, 160.5, 119.5, -0.01] });
    m.cameras
        .insert(4, ColmapCamera { model: CameraModel::Radial, width: 320, height: 240, params: vec![252.0, 160.0, 120.0, 0.02, -0.003] });
    let distortion = Distortion { k1: -0.1, k2: 0.01, p1: 1e-4, p2: -2e-4 };
    m.cameras.insert(5, ColmapCamera::opencv(&k, distortion, 640, 480));
    let pose = |angle: f64, t: [f64; 3]| Rigid3::new(DMat3::from_rotation_y(angle) * DMat3::from_rotation_x(0.1), DVec3::from_array(t));
    let image =
        |camera_id, camera_from_world, name: &str, points2d| ColmapImage { camera_id, camera_from_world, name: name.into(), points2d };
    m.images.insert(
        1,
        image(
            1,
            pose(0.3, [0.1, -0.2, 3.0]),
            "cam0/00000.png",
            vec![
                Point2D { xy: [10.5, 20.25], point3d_id: Some(7) },
                Point2D { xy: [1.0, 2.0], point3d_id: None },
                Point2D { xy: [100.125, 7.75], point3d_id: Some(9) },
            ],
        ),
    );
    m.images.insert(2, image(1, Rigid3::IDENTITY, "cam1/00000.png", vec![]));
    m.images.insert(3, image(2, pose(-0.2, [1.0, 0.0, 2.5]), "cam2/00000.png", vec![Point2D { xy: [5.0, 6.0], point3d_id: Some(9) }]));
    m.images.insert(4, image(3, pose(0.05, [0.0, 0.5, 2.0]), "cam3/00000.png", vec![]));
    m.images.insert(5, image(4, pose(1.2, [-1.0, 0.0, 4.0]), "cam4/00000.png", vec![]));
    m.images.insert(6, image(5, pose(-2.9, [0.0, 0.0, 1.0]), "cam5/00001.png", vec![]));
    m.points3d.insert(7, ColmapPoint3D { xyz: [1.0, 2.0, 3.0], rgb: [1, 2, 3], error: 0.5, track: vec![(1, 0)] });
    m.points3d.insert(9, ColmapPoint3D { xyz: [-0.5, 0.25, 6.0], rgb: [200, 100, 0], error: 1.25, track: vec![(1, 2), (3, 0)] });
    m
}

/// Equality up to the rotation's trip through a quaternion (COLMAP renormalises it on reading).
fn assert_same_model(a: &ColmapModel, b: &ColmapModel) {
    assert_eq!(a.cameras, b.cameras);
    assert_eq!(a.points3d, b.points3d);
    assert_eq!(a.images.keys().collect::<Vec<_>>(), b.images.keys().collect::<Vec<_>>());
    for (id, im) in &a.images {
        let other = &b.images[id];
        assert_eq!((&im.name, im.camera_id, &im.points2d), (&other.name, other.camera_id, &other.points2d));
        let d = im.camera_from_world.rotation - other.camera_from_world.rotation;
        assert!(d.to_cols_array().iter().all(|v| v.abs() < 1e-14), "image {id}: {d:?}");
        assert!((im.camera_from_world.translation - other.camera_from_world.translation).abs().max_element() < 1e-14);
    }
}

#[test]
fn model_dirs_round_trip_in_both_forms() {
    let tmp = tempfile::tempdir().unwrap();
    let m = sample_model();
    for format in [ColmapFormat::Text, ColmapFormat::Binary] {
        let dir = tmp.path().join(format.extension());
        m.write_dir(&dir, format).unwrap();
        assert_eq!(ColmapModel::detect_format(&dir).unwrap(), format);
        assert_same_model(&ColmapModel::read_dir(&dir).unwrap(), &m);
        for name in format.file_names() {
            assert!(dir.join(name).is_file());
        }
    }
}

#[test]
fn model_dirs_prefer_binary_and_replace_the_other_form() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("sparse");
    let m = sample_model();
    m.write_dir(&dir, ColmapFormat::Text).unwrap();
    // Both forms present (written by hand): binary wins.
    let mut other = m.clone();
    other.points3d.clear();
    std::fs::write(dir.join("cameras.bin"), other.cameras_bin()).unwrap();
    std::fs::write(dir.join("images.bin"), other.images_bin()).unwrap();
    std::fs::write(dir.join("points3D.bin"), other.points3d_bin()).unwrap();
    assert_eq!(ColmapModel::detect_format(&dir).unwrap(), ColmapFormat::Binary);
    assert!(ColmapModel::read_dir(&dir).unwrap().points3d.is_empty());
    // Writing text removes the binary files, so the new model is what a reader finds.
    m.write_dir(&dir, ColmapFormat::Text).unwrap();
    assert!(!dir.join("cameras.bin").exists());
    assert_same_model(&ColmapModel::read_dir(&dir).unwrap(), &m);
    // A model without points3D reads as one without points.
    std::fs::remove_file(dir.join("points3D.txt")).unwrap();
    assert!(ColmapModel::read_dir(&dir).unwrap().points3d.is_empty());
}

#[test]
fn model_dir_errors_are_clear() {
    let tmp = tempfile::tempdir().unwrap();
    let err = ColmapModel::read_dir(tmp.path()).unwrap_err().to_string();
    assert!(err.contains("no COLMAP model here"), "{err}");
    let notes = tmp.path().join("notes");
    std::fs::create_dir(&notes).unwrap();
    std::fs::write(notes.join("todo.txt"), "mine").unwrap();
    let err = sample_model().write_dir(&notes, ColmapFormat::Binary).unwrap_err().to_string();
    assert!(err.contains("refusing"), "{err}");
    assert_eq!(std::fs::read_dir(&notes).unwrap().count(), 1);
    // Errors inside a folder name the file by its path.
    let dir = tmp.path().join("bad");
    sample_model().write_dir(&dir, ColmapFormat::Binary).unwrap();
    let bytes = std::fs::read(dir.join("images.bin")).unwrap();
    std::fs::write(dir.join("images.bin"), &bytes[..bytes.len() - 3]).unwrap();
    let err = ColmapModel::read_dir(&dir).unwrap_err().to_string();
    assert!(err.starts_with(&dir.join("images.bin").display().to_string()), "{err}");
    std::fs::remove_file(dir.join("images.bin")).unwrap();
    let err = ColmapModel::read_dir(&dir).unwrap_err().to_string();
    assert!(err.contains("images.bin"), "{err}");
}

/// Runs `colmap model_converter`; `None` when no `colmap` is installed.
fn colmap_convert(input: &Path, output: &Path, output_type: &str) -> Option<()> {
    std::fs::create_dir_all(output).unwrap();
    let result = Command::new("colmap")
        .args(["model_converter", "--input_path"])
        .arg(input)
        .arg("--output_path")
        .arg(output)
        .args(["--output_type", output_type])
        .output();
    match result {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => panic!("running colmap: {e}"),
        Ok(out) => {
            assert!(out.status.success(), "colmap model_converter failed: {}", String::from_utf8_lossy(&out.stderr));
            Some(())
        }
    }
}

#[test]
fn colmap_reads_what_we_write_and_we_read_what_it_writes() {
    let tmp = tempfile::tempdir().unwrap();
    let m = sample_model();
    // Ours (binary) -> COLMAP -> text -> ours.
    let ours_bin = tmp.path().join("ours_bin");
    m.write_dir(&ours_bin, ColmapFormat::Binary).unwrap();
    let theirs_txt = tmp.path().join("theirs_txt");
    if colmap_convert(&ours_bin, &theirs_txt, "TXT").is_none() {
        println!("note: colmap is not on PATH; skipping the COLMAP interoperation test");
        return;
    }
    assert_eq!(ColmapModel::detect_format(&theirs_txt).unwrap(), ColmapFormat::Text);
    assert_same_model(&ColmapModel::read_dir(&theirs_txt).unwrap(), &m);
    // Ours (text) -> COLMAP -> binary -> ours.
    let ours_txt = tmp.path().join("ours_txt");
    m.write_dir(&ours_txt, ColmapFormat::Text).unwrap();
    let theirs_bin = tmp.path().join("theirs_bin");
    colmap_convert(&ours_txt, &theirs_bin, "BIN").unwrap();
    assert_same_model(&ColmapModel::read_dir(&theirs_bin).unwrap(), &m);
    // With one entry per file (COLMAP keeps entries in hash maps, so longer files may come in
    // another order) and an exact quaternion, COLMAP's binary files equal ours byte for byte.
    let mut single = ColmapModel::default();
    single.cameras.insert(3, m.cameras[&5].clone());
    let mut image = m.images[&1].clone();
    (image.camera_id, image.camera_from_world.rotation) = (3, DMat3::IDENTITY);
    single.images.insert(1, image);
    single.points3d.insert(9, ColmapPoint3D { track: vec![(1, 2)], ..m.points3d[&9].clone() });
    let (ours, theirs) = (tmp.path().join("single_txt"), tmp.path().join("single_bin"));
    single.write_dir(&ours, ColmapFormat::Text).unwrap();
    colmap_convert(&ours, &theirs, "BIN").unwrap();
    let ours_bytes = [single.cameras_bin(), single.images_bin(), single.points3d_bin()];
    for (name, ours_bytes) in ColmapFormat::Binary.file_names().into_iter().zip(ours_bytes) {
        assert_eq!(std::fs::read(theirs.join(name)).unwrap(), ours_bytes, "{name}");
    }
}
