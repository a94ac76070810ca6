//! The background plate of one still camera's frames, for looking at: reads every image of a
//! folder in name order, streams them through [`PlateEstimator`] and writes the plate, its
//! confidence (gray, white = the plate's colour was seen in every frame) and, for comparison, the
//! per-pixel median of the same frames.
//!
//! `cargo run --release -p dynview-sfm --example plates FRAMES_DIR OUT_PREFIX`, e.g. on a camera
//! of `../shared/data/panoptic-basketball-arc/cams/cam11`.

#[path = "common/frames.rs"]
mod frames;

use anyhow::{Context, bail};
use dynview_sfm::dense::plates::{PlateEstimator, PlateOptions};
use image::{GrayImage, RgbImage};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [dir, out] = args.as_slice() else { bail!("usage: plates FRAMES_DIR OUT_PREFIX") };
    let frames: Vec<RgbImage> = frames::frame_paths(dir)?.iter().map(frames::read_frame).collect::<anyhow::Result<_>>()?;
    let Some(first) = frames.first() else { bail!("{dir}: no .jpg or .png frames") };
    let mut estimator = PlateEstimator::new(first.width(), first.height(), PlateOptions::default())?;
    for frame in &frames {
        estimator.push(frame)?;
    }
    let plate = estimator.plate();
    plate.image.save(format!("{out}_plate.png"))?;
    let confidence = plate.confidence.iter().map(|c| (c * 255.0).round() as u8).collect();
    GrayImage::from_raw(first.width(), first.height(), confidence).context("confidence size")?.save(format!("{out}_confidence.png"))?;
    let mut median = RgbImage::new(first.width(), first.height());
    let mut values = vec![0u8; frames.len()];
    for (i, byte) in median.iter_mut().enumerate() {
        for (v, f) in values.iter_mut().zip(&frames) {
            *v = f.as_raw()[i];
        }
        *byte = *values.select_nth_unstable(frames.len() / 2).1;
    }
    median.save(format!("{out}_median.png"))?;
    let low = plate.confidence.iter().filter(|&&c| c < 0.5).count() as f64 / plate.confidence.len() as f64;
    println!("{} frames, {} state bytes; pixels with confidence under 0.5: {:.2}%", plate.frames, estimator.state_bytes(), 100.0 * low);
    Ok(())
}
