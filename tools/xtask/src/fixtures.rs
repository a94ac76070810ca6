//! Fixtures of the browser tests, made with the `dynview` CLI: a small synthetic event, its
//! native renders (the reference the wasm and page renders are compared with), a corrupted
//! copy of its package, and a bundle of the small package for `include_bytes!` in the wasm
//! tests.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::Context;

use crate::util::run_step;

/// Writes every file under `dir` into one bundle: per file, a little-endian `u32` name length,
/// the name (relative, `/`-separated), a `u64` data length and the data.
fn write_bundle(dir: &Path, out: &Path) -> anyhow::Result<()> {
    fn walk(dir: &Path, root: &Path, files: &mut Vec<(String, PathBuf)>) -> anyhow::Result<()> {
        let mut entries: Vec<_> = std::fs::read_dir(dir)?.collect::<Result<_, _>>()?;
        entries.sort_by_key(|e| e.path());
        for entry in entries {
            let path = entry.path();
            if path.is_dir() {
                walk(&path, root, files)?;
            } else {
                let rel = path.strip_prefix(root)?.to_string_lossy().replace('\\', "/");
                files.push((rel, path));
            }
        }
        Ok(())
    }
    let mut files = Vec::new();
    walk(dir, dir, &mut files)?;
    let mut bytes = Vec::new();
    for (name, path) in files {
        let data = std::fs::read(&path)?;
        bytes.extend_from_slice(&(name.len() as u32).to_le_bytes());
        bytes.extend_from_slice(name.as_bytes());
        bytes.extend_from_slice(&(data.len() as u64).to_le_bytes());
        bytes.extend_from_slice(&data);
    }
    std::fs::write(out, &bytes).with_context(|| format!("cannot write {}", out.display()))?;
    Ok(())
}

/// A synthetic event for browser tests with its native renders of the held-out path.
pub struct BrowserFixture {
    /// The event folder (`scene/`, `camera_path.json`, ...).
    pub event: PathBuf,
    /// A copy of the package whose `clouds.bin` is corrupted.
    pub corrupt_scene: PathBuf,
    /// The bundle of the wasm tests (scene, path and native renders).
    pub bundle: PathBuf,
}

/// Makes (or reuses) the fixture under `root` with the `dynview` binary `dynview`:
/// `cameras` cameras, `frames` frames of `width x height`.
pub fn browser_fixture(dynview: &Path, root: &Path, frames: u32, width: u32, height: u32) -> anyhow::Result<BrowserFixture> {
    let event = root.join("event");
    let native_render = root.join("native");
    let corrupt_scene = root.join("corrupt");
    let bundle = root.join("bundle.bin");
    let stamp = root.join("fixture.json");
    let config = format!("{{\"frames\":{frames},\"width\":{width},\"height\":{height},\"v\":1}}");
    let binary_time = std::fs::metadata(dynview).and_then(|m| m.modified()).ok();
    let stamp_time = std::fs::metadata(&stamp).and_then(|m| m.modified()).ok();
    let current = std::fs::read_to_string(&stamp).is_ok_and(|s| s == config) && stamp_time >= binary_time;
    if !current {
        let mut synth = Command::new(dynview);
        synth.arg("synth").arg("--out").arg(&event).args(["--cameras", "4", "--no-video"]);
        synth.args(["--frames", &frames.to_string(), "--width", &width.to_string(), "--height", &height.to_string()]);
        run_step("make the browser-test event", synth)?;
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
        let staging = root.join("bundle");
        if staging.exists() {
            std::fs::remove_dir_all(&staging)?;
        }
        copy_dir(&event.join("scene"), &staging.join("scene"))?;
        std::fs::copy(event.join("camera_path.json"), staging.join("camera_path.json"))?;
        for i in 0..frames.min(2) {
            let name = format!("{i:05}.png");
            std::fs::create_dir_all(staging.join("native"))?;
            std::fs::copy(native_render.join(&name), staging.join("native").join(&name))?;
        }
        write_bundle(&staging, &bundle)?;
        std::fs::write(&stamp, config)?;
    }
    Ok(BrowserFixture { event, corrupt_scene, bundle })
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
