//! `dynview import` (COLMAP, Qualisys, Middlebury) and `export-colmap` as a user runs them.

use std::fs;
use std::path::Path;
use std::process::Command;

use dynview_core::scene::{Manifest, PoseEntry, ScenePackage};
use dynview_interchange::poses::EventPoses;

fn dynview(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dynview")).args(args).output().expect("run dynview");
    (out.status.success(), format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr)))
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A tiny synthetic event (3 cameras, 2 frames of 32x18, no videos) in `event`.
fn synth(event: &Path) -> Manifest {
    let (ok, log) =
        dynview(&["synth", "--out", path(event), "--cameras", "3", "--frames", "2", "--width", "32", "--height", "18", "--no-video"]);
    assert!(ok, "{log}");
    ScenePackage::open(event.join("scene")).unwrap().manifest().clone()
}

fn import(model: &Path, out: &Path) -> EventPoses {
    let (ok, log) = dynview(&["import", path(model), "--out", path(out)]);
    assert!(ok, "{log}");
    EventPoses::read(out).unwrap()
}

fn max_pose_difference(a: &PoseEntry, b: &PoseEntry) -> f64 {
    let values = |p: &PoseEntry| p.rotation.into_iter().flatten().chain(p.translation).collect::<Vec<_>>();
    values(a).iter().zip(values(b)).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

/// Checks that `poses` holds the package's cameras, intrinsics and poses (to 1e-9), with frame
/// files `<t:05>.<extension>`.
fn assert_poses_match_package(poses: &EventPoses, manifest: &Manifest, extension: &str) {
    assert_eq!(poses.cameras.len(), manifest.cameras.len());
    for (camera, entry) in poses.cameras.iter().zip(&manifest.cameras) {
        assert_eq!((&camera.name, camera.width, camera.height), (&entry.name, entry.width, entry.height));
        assert_eq!(camera.distortion, [0.0; 4]);
        let (a, b) = (camera.intrinsics, entry.intrinsics);
        assert!([a.fx - b.fx, a.fy - b.fy, a.cx - b.cx, a.cy - b.cy].iter().all(|d| d.abs() < 1e-9), "{a:?} vs {b:?}");
        assert_eq!(camera.frames.len(), manifest.time_step_count as usize);
        for (t, frame) in camera.frames.iter().enumerate() {
            let pose = &entry.pose(t as u32);
            assert_eq!(frame.file, format!("{t:05}.{extension}"));
            let d = max_pose_difference(frame.camera_from_world.as_ref().unwrap(), pose);
            assert!(d < 1e-9, "{}/{}: pose differs by {d}", camera.name, frame.file);
        }
    }
}

#[test]
fn export_then_import_gives_the_package_poses_in_text_and_binary() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    let manifest = synth(&event);
    let extension = manifest.frame_format.extension();
    let scene = event.join("scene");
    for (flag, files) in
        [(None, ["cameras.txt", "images.txt", "points3D.txt"]), (Some("--binary"), ["cameras.bin", "images.bin", "points3D.bin"])]
    {
        let model = tmp.path().join(format!("model{}", flag.unwrap_or("")));
        let mut args = vec!["export-colmap", path(&scene), "--out", path(&model)];
        args.extend(flag);
        let (ok, log) = dynview(&args);
        assert!(ok, "{log}");
        assert!(log.contains("3 cameras, 6 images"), "{log}");
        for file in files {
            assert!(model.join(file).is_file(), "{file} missing");
        }
        let poses_json = tmp.path().join(format!("poses{}.json", flag.unwrap_or("")));
        let (ok, log) = dynview(&["import", path(&model), "--out", path(&poses_json)]);
        assert!(ok, "{log}");
        assert!(log.contains("3 cameras, 6 frames, 6 registered"), "{log}");
        assert_poses_match_package(&EventPoses::read(&poses_json).unwrap(), &manifest, extension);
        // Exporting again over the earlier model replaces it.
        let (ok, log) = dynview(&args);
        assert!(ok, "{log}");
    }

    // A poses.json is a source too, and survives the round trip.
    let poses_json = tmp.path().join("poses.json");
    let poses = import(&tmp.path().join("model"), &poses_json);
    let again = tmp.path().join("again");
    let (ok, log) = dynview(&["export-colmap", path(&poses_json), "--out", path(&again), "--binary"]);
    assert!(ok, "{log}");
    let back = import(&again, &tmp.path().join("back.json"));
    assert_poses_match_package(&back, &manifest, extension);
    assert_eq!(back.cameras.iter().map(|c| &c.name).collect::<Vec<_>>(), poses.cameras.iter().map(|c| &c.name).collect::<Vec<_>>());
}

#[test]
fn a_video_package_exports_its_frames_as_the_images_the_model_names() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    let manifest = synth(&event);
    let video = tmp.path().join("video");
    let (ok, log) = dynview(&["repack", path(&event.join("scene")), "--out", path(&video)]);
    assert!(ok, "{log}");
    let package = ScenePackage::open(&video).unwrap();
    assert!(package.manifest().frame_format.is_video());
    let model = tmp.path().join("model");
    let (ok, log) = dynview(&["export-colmap", path(&video), "--out", path(&model)]);
    assert!(ok, "{log}");
    assert!(log.contains(&format!("its images are in {}", model.join("images").display())), "{log}");
    let poses = import(&model, &tmp.path().join("poses.json"));
    assert_poses_match_package(&poses, &manifest, "jpg");
    for (c, camera) in poses.cameras.iter().enumerate() {
        for (t, frame) in camera.frames.iter().enumerate() {
            let image = image::open(model.join("images").join(&camera.name).join(&frame.file)).unwrap().to_rgb8();
            let stored = package.read_frame(c, t as u32).unwrap().to_rgb8();
            assert_eq!(image.dimensions(), stored.dimensions());
            let mean_error = image.as_raw().iter().zip(stored.as_raw()).map(|(a, b)| f64::from(a.abs_diff(*b))).sum::<f64>()
                / image.as_raw().len() as f64;
            assert!(mean_error < 4.0, "{}/{}: mean difference {mean_error} code values", camera.name, frame.file);
        }
    }
    // An image package's files are copied as they are, on request.
    let images = tmp.path().join("copied");
    let (ok, log) =
        dynview(&["export-colmap", path(&event.join("scene")), "--out", path(&tmp.path().join("m2")), "--images", path(&images)]);
    assert!(ok, "{log}");
    let extension = manifest.frame_format.extension();
    let first = format!("{}/00001.{extension}", manifest.cameras[2].name);
    assert_eq!(fs::read(images.join(&first)).unwrap(), fs::read(event.join("scene/frames").join(&first)).unwrap());
    // A folder that holds something else is left alone.
    fs::write(images.join("notes.txt"), "mine").unwrap();
    let (ok, log) =
        dynview(&["export-colmap", path(&event.join("scene")), "--out", path(&tmp.path().join("m3")), "--images", path(&images)]);
    assert!(!ok && log.contains("\"notes.txt\"") && log.contains("refusing"), "{log}");
    assert_eq!(fs::read_to_string(images.join("notes.txt")).unwrap(), "mine");
    assert!(!tmp.path().join("m3/cameras.txt").exists(), "nothing is written when the images cannot be");
}

#[test]
fn imports_the_synth_ground_truth_model() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    let manifest = synth(&event);
    let (ok, log) = dynview(&["import", path(&event.join("colmap")), "--out", path(&tmp.path().join("gt.json"))]);
    assert!(ok, "{log}");
    assert!(log.contains("read text COLMAP model"), "{log}");
    // The ground-truth model names its images `<camera>/<t:05>.png`.
    assert_poses_match_package(&EventPoses::read(&tmp.path().join("gt.json")).unwrap(), &manifest, "png");
}

#[test]
fn corrupt_models_give_errors_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    synth(&event);
    let out = tmp.path().join("poses.json");

    let binary = tmp.path().join("binary");
    let (ok, log) = dynview(&["export-colmap", path(&event.join("scene")), "--out", path(&binary), "--binary"]);
    assert!(ok, "{log}");
    let images_bin = binary.join("images.bin");
    let bytes = fs::read(&images_bin).unwrap();
    fs::write(&images_bin, &bytes[..bytes.len() - 5]).unwrap();
    let (ok, log) = dynview(&["import", path(&binary), "--out", path(&out)]);
    assert!(!ok);
    assert!(log.contains("images.bin: image 5 (id 6)") && log.contains("truncated"), "{log}");

    let text = tmp.path().join("text");
    let (ok, log) = dynview(&["export-colmap", path(&event.join("scene")), "--out", path(&text)]);
    assert!(ok, "{log}");
    let images_txt = text.join("images.txt");
    let contents = fs::read_to_string(&images_txt).unwrap();
    let line = contents.lines().find(|l| l.starts_with("2 ")).unwrap();
    let mut fields: Vec<&str> = line.split(' ').collect();
    fields[5] = "nan";
    fs::write(&images_txt, contents.replace(line, &fields.join(" "))).unwrap();
    let (ok, log) = dynview(&["import", path(&text), "--out", path(&out)]);
    assert!(!ok);
    assert!(log.contains("images.txt:") && log.contains("field `TX`: not finite"), "{log}");

    // Names that are not `<camera>/<frame file>` are named.
    fs::write(&images_txt, contents.replace("cam01/00001.jpg", "loose.jpg")).unwrap();
    let (ok, log) = dynview(&["import", path(&text), "--out", path(&out)]);
    assert!(!ok);
    assert!(log.contains("image 4 (loose.jpg): name must be <camera>/<frame file>"), "{log}");
    assert!(!out.exists(), "no poses.json is written on failure");
}

#[test]
fn refuses_folders_that_are_not_models() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    synth(&event);
    let mine = tmp.path().join("mine");
    fs::create_dir(&mine).unwrap();
    fs::write(mine.join("notes.txt"), "keep me").unwrap();
    let (ok, log) = dynview(&["export-colmap", path(&event.join("scene")), "--out", path(&mine)]);
    assert!(!ok);
    assert!(log.contains("is not a COLMAP model folder") && log.contains("refusing"), "{log}");
    assert_eq!(fs::read_dir(&mine).unwrap().count(), 1);
    let (ok, log) = dynview(&["import", path(&mine), "--out", path(&tmp.path().join("p.json"))]);
    assert!(!ok);
    assert!(log.contains("no COLMAP model here"), "{log}");
}

#[test]
fn colmap_itself_reads_the_export() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    let manifest = synth(&event);
    let binary = tmp.path().join("binary");
    let (ok, log) = dynview(&["export-colmap", path(&event.join("scene")), "--out", path(&binary), "--binary"]);
    assert!(ok, "{log}");
    let text = tmp.path().join("text");
    fs::create_dir(&text).unwrap();
    let run = Command::new("colmap")
        .args(["model_converter", "--input_path", path(&binary), "--output_path", path(&text), "--output_type", "TXT"])
        .output();
    let output = match run {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            println!("note: colmap is not on PATH; skipping the COLMAP interoperation test");
            return;
        }
        other => other.unwrap(),
    };
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let poses = import(&text, &tmp.path().join("poses.json"));
    assert_poses_match_package(&poses, &manifest, manifest.frame_format.extension());
}

#[test]
fn imports_qualisys_and_middlebury_calibrations() {
    let tmp = tempfile::tempdir().unwrap();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
    let out = tmp.path().join("rig.json");
    let (ok, log) = dynview(&["import", path(&data.join("pose2sim-multiperson/Calib.qca.txt")), "--out", path(&out)]);
    assert!(ok, "{log}");
    assert!(log.contains("Qualisys") && log.contains("4 cameras"), "{log}");
    let rig = EventPoses::read(&out).unwrap();
    assert_eq!(rig.cameras.iter().map(|c| c.name.as_str()).collect::<Vec<_>>(), ["cam01", "cam02", "cam03", "cam04"]);

    // A Middlebury ring: the sizes come from the images beside the calibration.
    let ring = tmp.path().join("ring");
    fs::create_dir(&ring).unwrap();
    let par = ring.join("ring_par.txt");
    fs::write(&par, "1\nv1.png 500 0 31.5 0 500 23.5 0 0 1 1 0 0 0 1 0 0 0 1 0 0 2\n").unwrap();
    let (ok, log) = dynview(&["import", path(&par), "--out", path(&tmp.path().join("ring.json"))]);
    assert!(!ok && log.contains("v1.png") && log.contains("image size"), "{log}");
    image::RgbImage::new(64, 48).save(ring.join("v1.png")).unwrap();
    let (ok, log) = dynview(&["import", path(&par), "--out", path(&tmp.path().join("ring.json"))]);
    assert!(ok, "{log}");
    let ring_poses = EventPoses::read(&tmp.path().join("ring.json")).unwrap();
    assert_eq!((ring_poses.cameras[0].width, ring_poses.cameras[0].height), (64, 48));

    // Something else is named, and nothing is written.
    let notes = tmp.path().join("notes.txt");
    fs::write(&notes, "hello").unwrap();
    let (ok, log) = dynview(&["import", path(&notes), "--out", path(&tmp.path().join("x.json"))]);
    assert!(!ok && log.contains("notes.txt") && log.contains("not a calibration"), "{log}");
    assert!(!tmp.path().join("x.json").exists());
}
