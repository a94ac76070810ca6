//! Fixtures of the page's end-to-end tests, made with the `dynview` CLI: a small synthetic
//! event, its native renders (the reference the page's renders are compared with), a
//! corrupted copy of its package, and the package `prep` makes of the event filmed by
//! unsynchronized phones. (The wasm API's tests make their own fixture on the host:
//! `crates/dynview-web-fixture`.)

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::Context;

use crate::util::run_step;

/// A synthetic event for browser tests with its native renders of the held-out path.
pub struct BrowserFixture {
    /// The event folder (`scene/`, `camera_path.json`, ...).
    pub event: PathBuf,
    /// A copy of the package whose `clouds.bin` is corrupted.
    pub corrupt_scene: PathBuf,
    /// The package repacked with its frames as video (format v2).
    pub video_scene: PathBuf,
    /// The event filmed by phones started by hand (`dynview synth --unsync`: a portrait phone,
    /// a 60 fps one, a variable rate, sound tracks), with `truth/` its upright frames as
    /// filmed and `prep/` what `dynview prep` made of its videos (clocks from the sound).
    pub phones: PathBuf,
}

/// Makes (or reuses) the fixture under `root` with the `dynview` binary `dynview`:
/// `cameras` cameras, `frames` frames of `width x height`.
pub fn browser_fixture(dynview: &Path, root: &Path, frames: u32, width: u32, height: u32) -> anyhow::Result<BrowserFixture> {
    let event = root.join("event");
    let native_render = root.join("native");
    let corrupt_scene = root.join("corrupt");
    let video_scene = root.join("video");
    let phones = root.join("phones");
    let stamp = root.join("fixture.json");
    let config = format!("{{\"frames\":{frames},\"width\":{width},\"height\":{height},\"v\":4}}");
    let binary_time = std::fs::metadata(dynview).and_then(|m| m.modified()).ok();
    let stamp_time = std::fs::metadata(&stamp).and_then(|m| m.modified()).ok();
    let current = std::fs::read_to_string(&stamp).is_ok_and(|s| s == config) && stamp_time >= binary_time;
    if !current {
        let mut synth = Command::new(dynview);
        synth.arg("synth").arg("--out").arg(&event).args(["--cameras", "4", "--no-video"]);
        synth.args(["--frames", &frames.to_string(), "--width", &width.to_string(), "--height", &height.to_string()]);
        run_step("make the browser-test event", synth)?;
        balance_one_camera(&event.join("scene/scene.json"))?;
        let mut render = Command::new(dynview);
        render.arg("render").arg("--scene").arg(event.join("scene")).arg("--path").arg(event.join("camera_path.json"));
        render.arg("--out").arg(&native_render);
        run_step("render the browser-test reference natively", render)?;
        if corrupt_scene.exists() {
            std::fs::remove_dir_all(&corrupt_scene)?;
        }
        copy_dir(&event.join("scene"), &corrupt_scene)?;
        let clouds = corrupt_scene.join("clouds.bin");
        let mut bytes = std::fs::read(&clouds).context("fixture clouds.bin")?;
        bytes[0..8].copy_from_slice(b"NOTCLOUD");
        std::fs::write(&clouds, bytes)?;
        let mut repack = Command::new(dynview);
        repack.arg("repack").arg(event.join("scene")).arg("--out").arg(&video_scene).args(["--keyframe-every", "3"]);
        run_step("repack the browser-test package with video frames", repack)?;
        phones_fixture(dynview, &phones, width, height)?;
        std::fs::write(&stamp, config)?;
    }
    Ok(BrowserFixture { event, corrupt_scene, video_scene, phones })
}

/// The synthetic event filmed by unsynchronized phones (1.6 s, enough sound to align) and the
/// package `prep` makes of their videos, as a user would (clocks from the sound, the true poses
/// given; no densification, plates or hull, which the other fixtures' tests cover).
fn phones_fixture(dynview: &Path, root: &Path, width: u32, height: u32) -> anyhow::Result<()> {
    if root.exists() {
        std::fs::remove_dir_all(root).with_context(|| format!("cannot remove {}", root.display()))?;
    }
    let event = root.join("truth");
    let mut synth = Command::new(dynview);
    synth.arg("synth").arg("--unsync").arg("--out").arg(&event).args(["--cameras", "4", "--frames", "48"]);
    synth.args(["--width", &width.to_string(), "--height", &height.to_string()]);
    run_step("make the browser-test phones event", synth)?;
    let mut prep = Command::new(dynview);
    prep.arg("prep").arg("--input").arg(event.join("videos")).arg("--out").arg(root.join("prep"));
    prep.arg("--poses").arg(event.join("colmap")).args(["--no-densify", "--no-plates", "--no-hull"]);
    run_step("prepare the phones' videos", prep)?;
    Ok(())
}

/// Gives `cam01` of the fixture package a color balance, so that every comparison of the
/// browser's renders with the native ones (image and video packages) also checks that both
/// apply it. `dynview synth` writes none: its cameras share one response.
fn balance_one_camera(manifest: &Path) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(manifest).with_context(|| format!("reading {}", manifest.display()))?;
    let camera = "\"name\": \"cam01\",";
    anyhow::ensure!(text.matches(camera).count() == 1, "{}: expected one camera named cam01", manifest.display());
    let balance = "\"color_balance\": {\"gain\": [0.8, 0.9, 1.15], \"offset\": [0.06, 0.0, -0.05]},";
    std::fs::write(manifest, text.replace(camera, &format!("{camera} {balance}")))
        .with_context(|| format!("writing {}", manifest.display()))?;
    Ok(())
}

fn copy_dir(from: &Path, to: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(to)?;
    for entry in std::fs::read_dir(from)? {
        let entry = entry?;
        let target = to.join(entry.file_name());
        if entry.file_type()?.is_dir() {
            copy_dir(&entry.path(), &target)?;
        } else {
            std::fs::copy(entry.path(), &target)?;
        }
    }
    Ok(())
}
