use glam::{DMat3, DVec3};

use super::*;
use crate::colmap::tests::sample_model;
use crate::colmap::{CameraModel, ColmapFormat};
use dynview_core::scene::testing::small_manifest;

/// Two cameras, one distorted, with an unregistered frame.
fn sample_poses() -> EventPoses {
    let pose = |angle: f64, z: f64| Some(PoseEntry::from(Rigid3::new(DMat3::from_rotation_y(angle), DVec3::new(0.1, -0.2, z))));
    EventPoses {
        cameras: vec![
            CameraPoses {
                name: "left".into(),
                width: 640,
                height: 480,
                intrinsics: Intrinsics { fx: 500.0, fy: 501.0, cx: 319.5, cy: 239.25 },
                distortion: [0.0; 4],
                frames: vec![
                    FramePose { file: "00000.jpg".into(), camera_from_world: pose(0.1, 3.0) },
                    FramePose { file: "00001.jpg".into(), camera_from_world: None },
                    FramePose { file: "00002.jpg".into(), camera_from_world: pose(0.3, 3.5) },
                ],
            },
            CameraPoses {
                name: "right".into(),
                width: 320,
                height: 240,
                intrinsics: Intrinsics { fx: 260.0, fy: 260.0, cx: 160.0, cy: 119.5 },
                distortion: [-0.12, 0.03, 1e-4, -2e-4],
                frames: vec![
                    FramePose { file: "a.png".into(), camera_from_world: pose(-0.4, 2.0) },
                    FramePose { file: "b.png".into(), camera_from_world: pose(-0.5, 2.1) },
                ],
            },
        ],
    }
}

fn registered_only(poses: &EventPoses) -> EventPoses {
    let mut out = poses.clone();
    for camera in &mut out.cameras {
        camera.frames.retain(|f| f.camera_from_world.is_some());
    }
    out
}

fn assert_close(a: &EventPoses, b: &EventPoses, tolerance: f64) {
    assert_eq!(a.cameras.len(), b.cameras.len());
    for (ca, cb) in a.cameras.iter().zip(&b.cameras) {
        assert_eq!((&ca.name, ca.width, ca.height, ca.distortion), (&cb.name, cb.width, cb.height, cb.distortion));
        let (ka, kb) = (ca.intrinsics, cb.intrinsics);
        assert!([ka.fx - kb.fx, ka.fy - kb.fy, ka.cx - kb.cx, ka.cy - kb.cy].iter().all(|d| d.abs() <= tolerance), "{ka:?} {kb:?}");
        assert_eq!(ca.frames.len(), cb.frames.len());
        for (fa, fb) in ca.frames.iter().zip(&cb.frames) {
            assert_eq!(fa.file, fb.file);
            match (fa.camera_from_world, fb.camera_from_world) {
                (None, None) => {}
                (Some(pa), Some(pb)) => {
                    let values = |p: PoseEntry| p.rotation.into_iter().flatten().chain(p.translation).collect::<Vec<_>>();
                    let d = values(pa).iter().zip(values(pb)).fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()));
                    assert!(d <= tolerance, "{}/{}: poses differ by {d}", ca.name, fa.file);
                }
                other => panic!("registration differs: {other:?}"),
            }
        }
    }
}

#[test]
fn json_round_trip_is_exact() {
    let poses = sample_poses();
    poses.validate().unwrap();
    let json = poses.to_json_string();
    assert!(json.contains("\"camera_from_world\": null"), "{json}");
    assert_eq!(EventPoses::from_json_bytes(json.as_bytes(), POSES_FILE).unwrap(), poses);
    assert_eq!(poses.frame_count(), 5);
    assert_eq!(poses.registered_frame_count(), 4);
    assert!(poses.camera_from_world(0, 1).is_none());
    assert!(poses.camera_from_world(2, 0).is_none());
    let c = poses.camera_from_world(1, 1).unwrap();
    assert!((c.rotation - DMat3::from_rotation_y(-0.5)).abs().to_cols_array().iter().all(|v| *v < 1e-15));
}

#[test]
fn file_round_trip_is_atomic_and_validated() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join(POSES_FILE);
    sample_poses().write(&path).unwrap();
    assert_eq!(EventPoses::read(&path).unwrap(), sample_poses());
    let mut bad = sample_poses();
    bad.cameras[1].name = "left".into();
    let err = bad.write(&path).unwrap_err().to_string();
    assert!(err.contains("cameras[1].name"), "{err}");
    assert_eq!(EventPoses::read(&path).unwrap(), sample_poses());
    let err = EventPoses::read(&tmp.path().join("missing.json")).unwrap_err().to_string();
    assert!(err.contains("missing.json"), "{err}");
}

#[test]
fn colmap_round_trip_in_text_and_binary() {
    let poses = sample_poses();
    let model = poses.to_colmap();
    assert_eq!(model.cameras[&1].model, CameraModel::Pinhole);
    assert_eq!(model.cameras[&2].model, CameraModel::OpenCv);
    assert_eq!(model.cameras[&2].params[2], 160.5); // half-pixel shift
    let names: Vec<(u32, &str)> = model.images.iter().map(|(id, im)| (*id, im.name.as_str())).collect();
    assert_eq!(names, [(1, "left/00000.jpg"), (2, "left/00002.jpg"), (3, "right/a.png"), (4, "right/b.png")]);
    assert!(model.points3d.is_empty());
    let expected = registered_only(&poses);
    assert_close(&EventPoses::from_colmap(&model).unwrap(), &expected, 1e-15);
    let text = ColmapModel::from_text(&model.cameras_txt(), &model.images_txt(), &model.points3d_txt()).unwrap();
    assert_close(&EventPoses::from_colmap(&text).unwrap(), &expected, 1e-15);
    let binary = ColmapModel::from_binary(&model.cameras_bin(), &model.images_bin(), &model.points3d_bin()).unwrap();
    assert_close(&EventPoses::from_colmap(&binary).unwrap(), &expected, 1e-15);
    // And through model folders.
    let tmp = tempfile::tempdir().unwrap();
    for format in [ColmapFormat::Text, ColmapFormat::Binary] {
        let dir = tmp.path().join(format.extension());
        model.write_dir(&dir, format).unwrap();
        assert_close(&EventPoses::from_colmap(&ColmapModel::read_dir(&dir).unwrap()).unwrap(), &expected, 1e-15);
    }
}

#[test]
fn from_colmap_maps_every_camera_model() {
    let poses = EventPoses::from_colmap(&sample_model()).unwrap();
    let names: Vec<&str> = poses.cameras.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["cam0", "cam1", "cam2", "cam3", "cam4", "cam5"]);
    let by_name = |n: &str| poses.cameras.iter().find(|c| c.name == n).unwrap();
    assert_eq!(by_name("cam0").intrinsics, Intrinsics { fx: 500.0, fy: 510.0, cx: 319.5, cy: 239.5 });
    assert_eq!(by_name("cam2").intrinsics, Intrinsics { fx: 250.0, fy: 250.0, cx: 159.5, cy: 119.5 });
    assert_eq!((by_name("cam3").intrinsics.cx, by_name("cam3").distortion), (160.0, [-0.01, 0.0, 0.0, 0.0]));
    assert_eq!(by_name("cam4").distortion, [0.02, -0.003, 0.0, 0.0]);
    assert_eq!(by_name("cam5").distortion, [-0.1, 0.01, 1e-4, -2e-4]);
    assert_eq!(by_name("cam5").frames[0].file, "00001.png");
}

#[test]
fn from_colmap_sorts_and_checks_shared_intrinsics() {
    let mut model = sample_poses().to_colmap();
    // Renumber so that ids run against name order; frames still come out sorted.
    let images: Vec<ColmapImage> = model.images.values().cloned().collect();
    model.images = images.into_iter().rev().enumerate().map(|(i, im)| (i as u32 + 10, im)).collect();
    let poses = EventPoses::from_colmap(&model).unwrap();
    assert_close(&poses, &registered_only(&sample_poses()), 1e-15);

    // A second COLMAP camera for one image of `left`: fine within 0.5%, an error beyond.
    let mut near = model.cameras[&1].clone();
    near.params[0] *= 1.004;
    model.cameras.insert(3, near);
    let left_last = *model.images.iter().find(|(_, im)| im.name == "left/00002.jpg").unwrap().0;
    model.images.get_mut(&left_last).unwrap().camera_id = 3;
    let poses = EventPoses::from_colmap(&model).unwrap();
    assert_eq!(poses.cameras[0].intrinsics.fx, 500.0, "the first frame's camera wins");
    model.cameras.get_mut(&3).unwrap().params[0] = 500.0 * 1.006;
    let err = EventPoses::from_colmap(&model).unwrap_err().to_string();
    assert!(err.contains("left/00002.jpg") && err.contains("left/00000.jpg") && err.contains("0.5%"), "{err}");
    model.cameras.get_mut(&3).unwrap().params[0] = 500.0;
    model.cameras.get_mut(&3).unwrap().width = 641;
    let err = EventPoses::from_colmap(&model).unwrap_err().to_string();
    assert!(err.contains("641x480"), "{err}");
}

#[test]
fn from_colmap_names_the_bad_image() {
    let base = sample_poses().to_colmap();
    let rename = |name: &str| {
        let mut m = base.clone();
        m.images.get_mut(&2).unwrap().name = name.into();
        EventPoses::from_colmap(&m).unwrap_err().to_string()
    };
    for bad in ["flat.jpg", "../x/a.jpg", "left/sub/a.jpg", "left/", ".hidden/a.jpg"] {
        let err = rename(bad);
        assert!(err.starts_with(&format!("COLMAP model: image 2 ({bad})")), "{err}");
    }
    let err = rename("left/00000.jpg");
    assert!(err.contains("same name as image 1"), "{err}");
    let mut m = base.clone();
    m.images.get_mut(&3).unwrap().camera_id = 9;
    let err = EventPoses::from_colmap(&m).unwrap_err().to_string();
    assert!(err.contains("image 3 (right/a.png): uses missing camera 9"), "{err}");
    let mut m = base;
    m.cameras.get_mut(&2).unwrap().params.pop();
    let err = EventPoses::from_colmap(&m).unwrap_err().to_string();
    assert!(err.contains("7 parameters"), "{err}");
    let err = EventPoses::from_colmap(&ColmapModel::default()).unwrap_err().to_string();
    assert!(err.starts_with("COLMAP model: cameras: must hold"), "{err}");
}

#[test]
fn from_manifest_names_frames_by_time_step() {
    let manifest = small_manifest(2, 3);
    let poses = EventPoses::from_manifest(&manifest);
    poses.validate().unwrap();
    assert_eq!(poses.cameras[1].frames[2].file, "00002.png");
    assert_eq!(poses.cameras[1].frames[2].camera_from_world, Some(manifest.cameras[1].poses[2]));
    assert_eq!(poses.cameras[0].intrinsics, manifest.cameras[0].intrinsics);
    // A video package has no frame files: its frames are named as `export-colmap` writes them.
    let mut video = manifest.clone();
    video.set_video_frames(30);
    assert_eq!(EventPoses::from_manifest(&video).cameras[1].frames[2].file, "00002.jpg");
}

fn expect_field(poses: &EventPoses, field: &str) {
    let err = poses.validate().unwrap_err().to_string();
    assert!(err.starts_with(&format!("poses.json: {field}: ")), "expected field {field} in: {err}");
}

#[test]
fn each_bad_field_is_named() {
    let base = sample_poses();
    let edit = |f: &dyn Fn(&mut EventPoses)| {
        let mut p = base.clone();
        f(&mut p);
        p
    };
    expect_field(&edit(&|p| p.cameras.clear()), "cameras");
    expect_field(&edit(&|p| p.cameras[1].name = "a/b".into()), "cameras[1].name");
    expect_field(&edit(&|p| p.cameras[1].name = "left".into()), "cameras[1].name");
    expect_field(&edit(&|p| p.cameras[0].width = 0), "cameras[0].width");
    expect_field(&edit(&|p| p.cameras[0].height = 16_385), "cameras[0].height");
    expect_field(&edit(&|p| p.cameras[0].intrinsics.cx = f64::NAN), "cameras[0].intrinsics.cx");
    expect_field(&edit(&|p| p.cameras[0].intrinsics.fy = -1.0), "cameras[0].intrinsics");
    expect_field(&edit(&|p| p.cameras[1].distortion[3] = f64::INFINITY), "cameras[1].distortion");
    expect_field(&edit(&|p| p.cameras[1].frames.clear()), "cameras[1].frames");
    expect_field(&edit(&|p| p.cameras[0].frames[1].file = "00000.jpg".into()), "cameras[0].frames[1].file");
    for bad in ["", "a/b.jpg", "a\\b.jpg", "..", "a b.jpg"] {
        expect_field(&edit(&|p| p.cameras[0].frames[2].file = bad.into()), "cameras[0].frames[2].file");
    }
    let frame_pose = "cameras[1].frames[1].camera_from_world";
    expect_field(&edit(&|p| p.cameras[1].frames[1].camera_from_world.as_mut().unwrap().rotation[0][1] += 1e-5), frame_pose);
    expect_field(&edit(&|p| p.cameras[1].frames[1].camera_from_world.as_mut().unwrap().translation[2] = f64::NAN), frame_pose);
    expect_field(&edit(&|p| p.cameras[1].frames[1].camera_from_world.as_mut().unwrap().translation[0] = 1e8), frame_pose);
    let mirror = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]];
    expect_field(&edit(&|p| p.cameras[1].frames[1].camera_from_world.as_mut().unwrap().rotation = mirror), frame_pose);
    let err = edit(&|p| p.cameras[1].frames[1].camera_from_world.as_mut().unwrap().rotation = mirror).validate().unwrap_err();
    assert!(err.to_string().ends_with("rotation is not orthonormal with determinant +1 (within 0.000001)"), "{err}");
    // Counts are capped.
    let mut many = base.clone();
    let camera = many.cameras[0].clone();
    many.cameras = (0..=MAX_POSE_CAMERAS).map(|i| CameraPoses { name: format!("c{i}"), ..camera.clone() }).collect();
    expect_field(&many, "cameras");
}

#[test]
fn json_errors_name_file_and_field() {
    let mut value: serde_json::Value = serde_json::from_str(&sample_poses().to_json_string()).unwrap();
    value["cameras"][1].as_object_mut().unwrap().remove("width");
    let err = EventPoses::from_json_bytes(value.to_string().as_bytes(), "in/poses.json").unwrap_err().to_string();
    assert!(err.starts_with("in/poses.json: ") && err.contains("width"), "{err}");
    value["cameras"][1]["width"] = 320.into();
    value["cameras"][1]["frames"][0]["camera_from_world"]["rotation"][0][0] = 2.0.into();
    let err = EventPoses::from_json_bytes(value.to_string().as_bytes(), "in/poses.json").unwrap_err().to_string();
    assert!(err.starts_with("in/poses.json: cameras[1].frames[0].camera_from_world: rotation is not orthonormal"), "{err}");
}
