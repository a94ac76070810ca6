//! The scene package end of `dynview prep`: a whole run, range runs joined by `dynview merge`
//! (byte for byte the same package), and `dynview export-ply`.

use std::path::{Path, PathBuf};
use std::process::Command;

use dynview_core::scene::ScenePackage;

fn dynview(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dynview")).args(args).output().expect("run dynview");
    (out.status.success(), format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr)))
}

fn s(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

/// A small synthetic event (3 cameras, 4 frames, 240x135) with its ground-truth COLMAP model.
fn event(dir: &Path) -> (PathBuf, PathBuf) {
    let event = dir.join("event");
    let (ok, log) =
        dynview(&["synth", "--out", s(&event), "--cameras", "3", "--frames", "4", "--width", "240", "--height", "135", "--no-video"]);
    assert!(ok, "{log}");
    (event.join("input"), event.join("colmap"))
}

fn prep(input: &Path, poses: &Path, out: &Path, extra: &[&str]) -> String {
    let mut args =
        vec!["prep", "--input", s(input), "--out", s(out), "--poses", s(poses), "--working-width", "160", "--target-points", "3000"];
    args.extend_from_slice(extra);
    let (ok, log) = dynview(&args);
    assert!(ok, "{log}");
    log
}

/// Every file under `root`, relative path and bytes.
fn files(root: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).expect("read dir") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                stack.push(path);
            } else {
                out.push((path.strip_prefix(root).expect("inside").to_path_buf(), std::fs::read(&path).expect("read")));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn ranges_joined_by_merge_equal_a_single_run_byte_for_byte() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (input, poses) = event(dir.path());
    let single = dir.path().join("single");
    let log = prep(&input, &poses, &single, &[]);
    assert!(log.contains("wrote") && single.join("scene/scene.json").is_file(), "{log}");

    // Two range jobs with their own output folders (no shared storage), one of them overlapping.
    let (first, second) = (dir.path().join("part-a"), dir.path().join("part-b"));
    let log = prep(&input, &poses, &first, &["--frames", "0..3"]);
    assert!(log.contains("dynview merge") && !first.join("scene").exists(), "a range writes no package: {log}");
    prep(&input, &poses, &second, &["--frames", "2..4"]);
    let merged = dir.path().join("merged");
    let (ok, log) = dynview(&["merge", s(&first), s(&second), "--out", s(&merged), "--name", "single"]);
    assert!(ok, "{log}");
    let (a, b) = (files(&single.join("scene")), files(&merged));
    assert_eq!(a.iter().map(|f| &f.0).collect::<Vec<_>>(), b.iter().map(|f| &f.0).collect::<Vec<_>>());
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{} differs between the single run and the merged ranges", name.display());
    }

    // A missing time step and outputs of different pose stages are refused, naming the problem.
    let (ok, log) = dynview(&["merge", s(&first), "--out", s(&dir.path().join("bad"))]);
    assert!(!ok && log.contains("time step 3 of 4") && log.contains("--frames 3..4"), "{log}");
    let other = dir.path().join("other");
    std::fs::create_dir_all(&other).expect("mkdir");
    let mut changed = dynview_interchange::poses::EventPoses::read(&second.join("poses.json")).expect("poses");
    changed.cameras[0].intrinsics.fx *= 1.01;
    changed.write(&other.join("poses.json")).expect("write");
    std::fs::create_dir_all(other.join("work/steps")).expect("mkdir");
    std::fs::copy(second.join("work/steps/settings.json"), other.join("work/steps/settings.json")).expect("copy");
    let (ok, log) = dynview(&["merge", s(&first), s(&other), "--out", s(&dir.path().join("bad"))]);
    assert!(!ok && log.contains("poses.json differs"), "{log}");
    assert!(!dir.path().join("bad").exists(), "nothing is left behind by a failed merge");
}

#[test]
fn the_package_has_working_size_frames_and_export_ply_writes_a_step() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (input, poses) = event(dir.path());
    let out = dir.path().join("prep");
    prep(&input, &poses, &out, &["--no-densify"]);
    let package = ScenePackage::open(out.join("scene")).expect("package");
    let camera = &package.manifest().cameras[0];
    assert_eq!((camera.width, camera.height), (160, 90));
    let truth =
        dynview_interchange::poses::EventPoses::from_colmap(&dynview_interchange::colmap::ColmapModel::read_dir(&poses).expect("model"))
            .expect("poses");
    let k = truth.cameras[0].intrinsics;
    assert!((camera.intrinsics.fx - k.fx * 160.0 / 240.0).abs() < 1e-9, "focal scaled with the frames");
    assert_eq!(package.read_frame(0, 3).expect("frame").width, 160);

    let ply = dir.path().join("t2.ply");
    let (ok, log) = dynview(&["export-ply", s(&out.join("scene")), "--frame", "2", "--out", s(&ply)]);
    assert!(ok, "{log}");
    let bytes = std::fs::read(&ply).expect("ply");
    let points = package.read_cloud(2).expect("cloud").len();
    assert!(points > 50, "{points} points");
    let header = format!("element vertex {points}\n");
    assert!(String::from_utf8_lossy(&bytes[..300.min(bytes.len())]).contains(&header), "PLY header counts the step's points");
    let (ok, log) = dynview(&["export-ply", s(&out.join("scene")), "--frame", "4"]);
    assert!(!ok && log.contains("time steps 0..3"), "{log}");
}
