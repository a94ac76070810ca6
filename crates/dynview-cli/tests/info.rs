//! `dynview info` and `dynview synth` as a user runs them.

use std::fs;
use std::path::Path;
use std::process::Command;

fn dynview(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dynview")).args(args).output().expect("run dynview");
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into_owned(), String::from_utf8_lossy(&out.stderr).into_owned())
}

fn synth_small(dir: &Path) {
    let out = dir.to_str().unwrap();
    let (ok, _, err) =
        dynview(&["synth", "--out", out, "--cameras", "3", "--frames", "3", "--width", "64", "--height", "36", "--no-video"]);
    assert!(ok, "{err}");
}

#[test]
fn info_summarises_a_valid_package() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    synth_small(&event);
    let (ok, stdout, stderr) = dynview(&["info", event.join("scene").to_str().unwrap()]);
    assert!(ok, "{stderr}");
    for needle in ["time steps  3", "cameras     3", "cam02", "points", "bounds", "MiB on disk"] {
        assert!(stdout.contains(needle), "missing {needle:?} in:\n{stdout}");
    }
}

#[test]
fn info_on_corrupted_packages_fails_naming_the_field() {
    let tmp = tempfile::tempdir().unwrap();
    let event = tmp.path().join("event");
    synth_small(&event);
    let scene = event.join("scene");
    let manifest = scene.join("scene.json");
    let text = fs::read_to_string(&manifest).unwrap();

    // A non-orthonormal rotation (the synthetic cameras stand still: one pose each).
    let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
    json["cameras"][1]["poses"][0]["rotation"][0][0] = serde_json::json!(1.5);
    fs::write(&manifest, json.to_string()).unwrap();
    let (ok, _, stderr) = dynview(&["info", scene.to_str().unwrap()]);
    assert!(!ok);
    assert!(stderr.contains("cameras[1].poses[0].rotation"), "{stderr}");
    fs::write(&manifest, &text).unwrap();

    // A flipped byte in a cloud block.
    let clouds = scene.join("clouds.bin");
    let good = fs::read(&clouds).unwrap();
    let mut bad = good.clone();
    let last = bad.len() - 3;
    bad[last] ^= 0x40;
    fs::write(&clouds, &bad).unwrap();
    let (ok, _, stderr) = dynview(&["info", scene.to_str().unwrap()]);
    assert!(!ok);
    assert!(stderr.contains("steps[2].crc32"), "{stderr}");
    fs::write(&clouds, &good).unwrap();

    // A truncated frame.
    let frame = scene.join("frames/cam00/00001.jpg");
    let bytes = fs::read(&frame).unwrap();
    fs::write(&frame, &bytes[..20]).unwrap();
    let (ok, _, stderr) = dynview(&["info", scene.to_str().unwrap()]);
    assert!(!ok);
    assert!(stderr.contains("cam00/00001.jpg"), "{stderr}");

    // Not a package at all.
    let (ok, _, stderr) = dynview(&["info", tmp.path().to_str().unwrap()]);
    assert!(!ok);
    assert!(stderr.contains("scene.json"), "{stderr}");
}

#[test]
fn synth_rejects_bad_options_clearly() {
    let tmp = tempfile::tempdir().unwrap();
    let (ok, _, stderr) = dynview(&["synth", "--out", tmp.path().join("e").to_str().unwrap(), "--cameras", "1"]);
    assert!(!ok);
    assert!(stderr.contains("cameras"), "{stderr}");
}
