//! What the examples that read a folder of frames share.

use std::path::PathBuf;

use anyhow::Context;
use image::RgbImage;

/// The `.jpg` and `.png` files of `dir`, in name order.
pub fn frame_paths(dir: &str) -> anyhow::Result<Vec<PathBuf>> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot list {dir}"))?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "jpg" || e == "png"))
        .collect();
    paths.sort();
    Ok(paths)
}

/// The frame at `path`, as RGB.
pub fn read_frame(path: &PathBuf) -> anyhow::Result<RgbImage> {
    image::open(path).map(|i| i.to_rgb8()).with_context(|| format!("cannot read {}", path.display()))
}
