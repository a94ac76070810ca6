//! `dynview prep` as a user runs it: known poses, clear errors.

use std::path::Path;
use std::process::Command;

fn dynview(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dynview")).args(args).output().expect("run dynview");
    (out.status.success(), format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr)))
}

fn synth(event: &Path) {
    let (ok, log) = dynview(&[
        "synth",
        "--out",
        event.to_str().unwrap(),
        "--cameras",
        "3",
        "--frames",
        "2",
        "--width",
        "64",
        "--height",
        "36",
        "--no-video",
    ]);
    assert!(ok, "{log}");
}

#[test]
fn known_poses_skip_estimation_and_equal_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let event = dir.path().join("event");
    synth(&event);
    let out = dir.path().join("prep");
    let input = event.join("input");
    let model = event.join("colmap");
    let (ok, log) =
        dynview(&["prep", "--input", input.to_str().unwrap(), "--out", out.to_str().unwrap(), "--poses", model.to_str().unwrap()]);
    assert!(ok, "{log}");
    assert!(log.contains("pose estimation (poses from"), "{log}");
    let written = dynview_interchange::poses::EventPoses::read(&out.join("poses.json")).unwrap();
    let truth =
        dynview_interchange::poses::EventPoses::from_colmap(&dynview_interchange::colmap::ColmapModel::read_dir(&model).unwrap()).unwrap();
    assert_eq!(written.cameras.len(), 3);
    for (w, t) in written.cameras.iter().zip(&truth.cameras) {
        assert_eq!((&w.name, w.frames.len()), (&t.name, t.frames.len()));
        for (a, b) in w.frames.iter().zip(&t.frames) {
            assert_eq!(a.camera_from_world, b.camera_from_world);
        }
    }
}

#[test]
fn bad_inputs_fail_with_the_file_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("prep");
    let empty = dir.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let (ok, log) = dynview(&["prep", "--input", empty.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(!ok && log.contains("no cameras found"), "{log}");
    std::fs::write(empty.join("cam1.mp4"), b"not a video").unwrap();
    let (ok, log) = dynview(&["prep", "--input", empty.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(!ok && log.contains("cam1.mp4") && log.contains("cannot decode"), "{log}");
    let (ok, log) = dynview(&["prep", "--input", empty.to_str().unwrap(), "--out", out.to_str().unwrap(), "--focal", "wide"]);
    assert!(!ok && log.contains("--focal"), "{log}");
    let (ok, log) = dynview(&["prep", "--input", empty.to_str().unwrap(), "--out", out.to_str().unwrap(), "--stop-after", "meshes"]);
    assert!(!ok && log.contains("unknown stage"), "{log}");
    for share in ["1.5", "-0.1", "NaN"] {
        let option = format!("--plate-repair-min-share={share}");
        let (ok, log) = dynview(&["prep", "--input", empty.to_str().unwrap(), "--out", out.to_str().unwrap(), &option]);
        assert!(!ok && log.contains("--plate-repair-min-share must be between 0 and 1"), "{share}: {log}");
    }
    for tolerance in ["0", "1", "NaN"] {
        let option = format!("--foreground-tolerance={tolerance}");
        let (ok, log) = dynview(&["prep", "--input", empty.to_str().unwrap(), "--out", out.to_str().unwrap(), &option]);
        assert!(!ok && log.contains("--foreground-tolerance must lie between 0 and 1"), "{tolerance}: {log}");
    }
    let (ok, log) = dynview(&["prep", "--input", empty.to_str().unwrap(), "--out", out.to_str().unwrap(), "--plate-consistent-views=0"]);
    assert!(!ok && log.contains("--plate-consistent-views must be at least 1"), "{log}");
}

/// The visual hull's points of a prep of the hand-held event in `event` (`None` when the
/// package stage carved no hull), with `extra` arguments.
fn hull_points_of_hand_held_prep(event: &Path, out: &Path, extra: &[&str]) -> Option<u64> {
    let (input, model) = (event.join("input"), event.join("colmap"));
    let mut args = vec!["prep", "--input", input.to_str().unwrap(), "--out", out.to_str().unwrap()];
    args.extend(["--poses", model.to_str().unwrap(), "--no-densify"]);
    args.extend(extra);
    let (ok, log) = dynview(&args);
    assert!(ok, "{log}");
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    report["package"]["hull_points"].as_u64()
}

#[test]
fn hand_held_cameras_carve_the_hull_from_plates_made_per_step() {
    let dir = tempfile::tempdir().unwrap();
    let event = dir.path().join("event");
    let size = ["--cameras", "5", "--frames", "16", "--width", "160", "--height", "90"];
    let (ok, log) = dynview(&[&["synth", "--out", event.to_str().unwrap(), "--handheld", "--no-video"][..], &size[..]].concat());
    assert!(ok, "{log}");
    // No camera stands still, so none has a plate of the whole event.
    let with = hull_points_of_hand_held_prep(&event, &dir.path().join("with"), &[]);
    assert!(with.is_some_and(|n| n > 0), "hull points with plates per step: {with:?}");
    let without = hull_points_of_hand_held_prep(&event, &dir.path().join("without"), &["--no-moving-plates"]);
    assert_eq!(without, None, "without plates per step no camera has a plate, so no hull");
}
