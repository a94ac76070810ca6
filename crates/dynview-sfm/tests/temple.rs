//! The keyframe reconstruction on a real weakly textured object: Middlebury's templeSparseRing
//! (16 views on a ring, `../shared/data`). Three views after a gap share fewer than 20
//! triangulated points with the rest, too few for PnP; one is placed from its verified pair with
//! a placed view, and then the others by PnP. Every view must be registered, accurately.

use std::sync::atomic::AtomicBool;

use dynview_eval::align::{PoseEvalOptions, evaluate_poses};
use dynview_eval::datasets::colmap_models::{poses_from_colmap, read_colmap_text};
use dynview_eval::datasets::sfm::prepare;
use dynview_eval::runs::sfm::OURS_MODEL_DIR;
use dynview_interchange::poses::{CameraPoses, EventPoses, FramePose};
use dynview_sfm::{PrepOptions, Stage, run};

#[test]
fn every_view_of_the_temple_ring_is_registered_accurately() {
    let dir = tempfile::tempdir().expect("temp dir");
    let dataset = prepare("temple", dir.path()).expect("the temple ring from ../shared/data/middlebury-temple-sparse-ring");
    let out = dir.path().join("out");
    let options = PrepOptions { keyframe_interval: 1, stop_after: Stage::Keyframes, ..PrepOptions::default() };
    let report = run(&dataset.images_dir, &out, &options, &|_, _, _| {}, &AtomicBool::new(false)).expect("prep");
    assert_eq!((report.keyframes_registered, report.keyframes), (16, 16), "placed from pairs: {:?}", report.keyframes_placed_from_pair);
    assert!(!report.keyframes_placed_from_pair.is_empty(), "PnP alone registered every view: the test no longer covers pair placement");
    let model = read_colmap_text(&out.join(OURS_MODEL_DIR)).expect("the keyframe model");
    let accuracy = evaluate_poses(&poses_from_colmap(&model), &dataset.ground_truth, PoseEvalOptions::default()).expect("alignment");
    eprintln!(
        "temple: {}/{} registered, rotation median {:.3} deg (max {:.3}), placed from pairs: {:?}",
        accuracy.registered,
        accuracy.ground_truth_images,
        accuracy.rotation_error_median_deg,
        accuracy.rotation_error_max_deg,
        report.keyframes_placed_from_pair
    );
    assert_eq!(accuracy.registered, 16);
    // Measured 0.177 deg (max 0.566) on 2026-11-25 (exact matching); COLMAP 3.8 registers 13
    // at 0.497. The issue asks 0.2.
    assert!(accuracy.rotation_error_median_deg <= 0.2, "rotation median {:.3} deg", accuracy.rotation_error_median_deg);
    assert!(accuracy.rotation_error_max_deg <= 0.6, "rotation max {:.3} deg", accuracy.rotation_error_max_deg);
}

/// Six views of the ring (every third), each its own camera: one pair shares enough to start,
/// no pair self-calibrates, and the other four views cannot be placed. Two views placed with a
/// guessed focal length are not trusted (measured: focal 45% short, relative rotation 10.6
/// degrees off); prep names them and the cameras left out. Given the focal length, the same two
/// views are kept (measured: 0.60 degrees off).
#[test]
fn two_views_placed_with_a_guessed_focal_length_are_refused_by_name() {
    let dir = tempfile::tempdir().expect("temp dir");
    let dataset = prepare("temple", dir.path()).expect("the temple ring from ../shared/data/middlebury-temple-sparse-ring");
    let files = ring_views(&dataset.images_dir);
    assert_eq!(files.len(), 16);
    let input = dir.path().join("six");
    let six: Vec<_> = files.iter().step_by(3).collect();
    let names = one_frame_cameras(&six, &input, |i| format!("cam{i}"));
    let options = PrepOptions { stop_after: Stage::Keyframes, ..PrepOptions::default() };
    let error = run(&input, &dir.path().join("guessed"), &options, &|_, _, _| {}, &AtomicBool::new(false))
        .expect_err("two views on a guessed focal length")
        .to_string();
    assert!(error.contains("only two views could be placed") && error.contains("not trusted"), "{error}");
    assert!(error.contains("could not be placed") && error.contains("--focal"), "{error}");
    let placed = names.iter().filter(|name| error.contains(&format!("{name} 00000.png"))).count();
    assert_eq!(placed, 2, "{error}");
    // The temple's true focal length: the same views are kept.
    let given = PrepOptions { focal_px_all: Some(1520.4), ..options };
    let report =
        run(&input, &dir.path().join("given"), &given, &|_, _, _| {}, &AtomicBool::new(false)).expect("prep with the focal length");
    assert_eq!(report.keyframes_registered, 2);
}

/// The ring's 16 views as 16 one-frame cameras, each with its own intrinsics: every camera
/// starts from the prior focal (1.2 x the longer side, half the true one); bundle adjustment
/// refines the placed cameras'. Three views share too few points for PnP and are placed from a
/// pair, under the placed cameras' median focal (under their own prior the pair's geometry
/// placed none of them: 13 of 16).
#[test]
fn every_view_of_the_ring_as_its_own_camera_is_registered() {
    let dir = tempfile::tempdir().expect("temp dir");
    let dataset = prepare("temple", dir.path()).expect("the temple ring from ../shared/data/middlebury-temple-sparse-ring");
    let files = ring_views(&dataset.images_dir);
    let input = dir.path().join("cameras");
    let names = one_frame_cameras(&files.iter().collect::<Vec<_>>(), &input, |i| format!("cam{i:02}"));
    let mut truth = dynview_eval::datasets::colmap_models::Poses::new();
    for (file, camera) in files.iter().zip(&names) {
        let name = file.strip_prefix(&dataset.images_dir).expect("inside the dataset").to_string_lossy().replace('\\', "/");
        truth.insert(format!("{camera}/00000.png"), dataset.ground_truth[&name]);
    }
    let out = dir.path().join("out");
    let options = PrepOptions { stop_after: Stage::Keyframes, ..PrepOptions::default() };
    let report = run(&input, &out, &options, &|_, _, _| {}, &AtomicBool::new(false)).expect("prep");
    let model = read_colmap_text(&out.join(OURS_MODEL_DIR)).expect("the keyframe model");
    let accuracy = evaluate_poses(&poses_from_colmap(&model), &truth, PoseEvalOptions::default()).expect("alignment");
    eprintln!(
        "16 one-frame cameras: {}/16 registered, rotation median {:.3} deg (max {:.3}), placed from pairs: {:?}",
        accuracy.registered, accuracy.rotation_error_median_deg, accuracy.rotation_error_max_deg, report.keyframes_placed_from_pair
    );
    assert_eq!((report.keyframes_registered, accuracy.registered), (16, 16), "placed from pairs: {:?}", report.keyframes_placed_from_pair);
    assert!(!report.keyframes_placed_from_pair.is_empty(), "PnP alone registered every view: the test no longer covers pair placement");
    assert!(accuracy.rotation_error_median_deg <= 1.0, "rotation median {:.3} deg", accuracy.rotation_error_median_deg);
}

/// What the user gives is kept: a calibration of the ring's camera keeps its focal length and
/// principal point exactly; a focal length given for one of the ring's views as 16 one-frame
/// cameras keeps that focal while the others are refined, each reported with its standard
/// deviation. (Before, bundle adjustment refined a given focal whenever some camera's was not
/// given, and a calibration's principal point always.)
#[test]
fn given_intrinsics_are_kept_as_given() {
    let dir = tempfile::tempdir().expect("temp dir");
    let dataset = prepare("temple", dir.path()).expect("the temple ring from ../shared/data/middlebury-temple-sparse-ring");
    let files = ring_views(&dataset.images_dir);
    let (name, truth) = dataset.intrinsics.iter().next().expect("the ring's camera");
    let calibration = EventPoses {
        cameras: vec![CameraPoses {
            name: name.clone(),
            width: 640,
            height: 480,
            intrinsics: *truth,
            distortion: [0.0; 4],
            frames: files
                .iter()
                .map(|f| FramePose { file: f.file_name().expect("a file").to_string_lossy().into_owned(), camera_from_world: None })
                .collect(),
        }],
    };
    let calibration_file = dir.path().join("calibration.json");
    calibration.write(&calibration_file).expect("write the calibration");
    let out = dir.path().join("calibrated");
    let options =
        PrepOptions { keyframe_interval: 1, stop_after: Stage::Keyframes, intrinsics: Some(calibration_file), ..PrepOptions::default() };
    let report = run(&dataset.images_dir, &out, &options, &|_, _, _| {}, &AtomicBool::new(false)).expect("prep with a calibration");
    assert_eq!(report.intrinsics_refined, vec!["focal kept as given, principal point kept as given".to_string()]);
    let model = read_colmap_text(&out.join(OURS_MODEL_DIR)).expect("the keyframe model");
    let params = &model.cameras.values().next().expect("one camera").params;
    // One focal length (the mean of fx and fy: 1520.4 and 1525.9 here); COLMAP's pixel centres
    // at +0.5.
    let focal_px = 0.5 * (truth.fx + truth.fy);
    assert_eq!(params[..3], [focal_px, truth.cx + 0.5, truth.cy + 0.5], "the calibration changed");

    let input = dir.path().join("cameras");
    let names = one_frame_cameras(&files.iter().collect::<Vec<_>>(), &input, |i| format!("cam{i:02}"));
    let out = dir.path().join("one-focal");
    let options = PrepOptions {
        stop_after: Stage::Keyframes,
        focal_px: [(names[0].clone(), focal_px)].into_iter().collect(),
        ..PrepOptions::default()
    };
    let report = run(&input, &out, &options, &|_, _, _| {}, &AtomicBool::new(false)).expect("prep with one focal length");
    assert!(report.intrinsics_refined[0].starts_with("focal kept as given, "), "{:?}", report.intrinsics_refined);
    assert!(report.intrinsics_refined[1..].iter().all(|n| n.starts_with("focal refined (known to ")), "{:?}", report.intrinsics_refined);
    let model = read_colmap_text(&out.join(OURS_MODEL_DIR)).expect("the keyframe model");
    let focal_of = |camera: &str| {
        let image = model.images.values().find(|i| i.name.starts_with(&format!("{camera}/"))).expect("registered");
        model.cameras[&image.camera_id].params[0]
    };
    assert_eq!(focal_of(&names[0]), focal_px, "the given focal changed");
    let refined: Vec<f64> = names[1..].iter().map(|n| focal_of(n)).collect();
    eprintln!("one focal given: the others' {refined:.1?} px (true {focal_px})");
    // They start from the prior (1.2 x 640 px, half the true focal) and are refined to it.
    assert!(refined.iter().all(|f| (f / focal_px - 1.0).abs() < 0.05), "{refined:?}");
}

/// Every view of the ring under `dir`, in file-name order.
fn ring_views(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut files = walk(dir);
    files.sort();
    files
}

/// Copies each of `views` into a camera folder of its own under `input`, as its one frame
/// `00000.png`; returns the cameras' names (`name(i)` for the i-th view).
fn one_frame_cameras(views: &[&std::path::PathBuf], input: &std::path::Path, name: impl Fn(usize) -> String) -> Vec<String> {
    views
        .iter()
        .enumerate()
        .map(|(i, file)| {
            let camera = name(i);
            let folder = input.join(&camera);
            std::fs::create_dir_all(&folder).expect("camera folder");
            std::fs::copy(file, folder.join("00000.png")).expect("copy");
            camera
        })
        .collect()
}

/// Every file under `dir`.
fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).expect("read dir").flatten() {
        let path = entry.path();
        if path.is_dir() {
            out.extend(walk(&path));
        } else {
            out.push(path);
        }
    }
    out
}
