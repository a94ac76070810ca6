//! How much of a still camera's foreground the shadow cue takes back, for looking at: the plate
//! of every frame of a folder, then for every `STRIDE`-th frame the soft foreground with and
//! without [`HullOptions::shadows`]; prints the share of pixels each calls foreground and writes,
//! for the middle frame, the frame with the pixels the cue takes back in magenta.
//!
//! `cargo run --release -p dynview-sfm --example shadows FRAMES_DIR OUT_PREFIX [STRIDE]`, e.g. on
//! a camera of `../shared/data/panoptic-basketball-arc/cams/cam11`.

#[path = "common/frames.rs"]
mod frames;

use anyhow::{Context, bail};
use dynview_sfm::dense::hull::{HullOptions, foreground};
use dynview_sfm::dense::plates::{PlateEstimator, PlateOptions};
use image::RgbImage;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (dir, out, stride) = match args.as_slice() {
        [dir, out] => (dir, out, 10),
        [dir, out, stride] => (dir, out, stride.parse().context("STRIDE must be a whole number")?),
        _ => bail!("usage: shadows FRAMES_DIR OUT_PREFIX [STRIDE]"),
    };
    let paths = frames::frame_paths(dir)?;
    let Some(first) = paths.first() else { bail!("{dir}: no .jpg or .png frames") };
    let first = frames::read_frame(first)?;
    let mut estimator = PlateEstimator::new(first.width(), first.height(), PlateOptions::default())?;
    for path in &paths {
        estimator.push(&frames::read_frame(path)?)?;
    }
    let plate = estimator.plate();
    let plain = HullOptions { shadows: false, ..HullOptions::default() };
    let shadows = HullOptions { shadows: true, ..HullOptions::default() };
    let share = |mask: &[f32]| mask.iter().filter(|&&v| v > 0.5).count() as f64 / mask.len() as f64;
    let (mut sum_plain, mut sum_shadows, mut count, mut changed) = (0.0, 0.0, 0, 0usize);
    for (k, path) in paths.iter().enumerate().step_by(stride.max(1)) {
        let frame = frames::read_frame(path)?;
        let a = foreground(&frame, &plate, &plain)?;
        let b = foreground(&frame, &plate, &shadows)?;
        sum_plain += share(&a.mask.data);
        sum_shadows += share(&b.mask.data);
        changed += a.keeps.data.iter().zip(&b.keeps.data).filter(|(x, y)| x != y).count();
        count += 1;
        if k / stride.max(1) == paths.len() / stride.max(1) / 2 {
            let mut marked: RgbImage = frame.clone();
            for (i, pixel) in marked.pixels_mut().enumerate() {
                if a.mask.data[i] > 0.5 && b.mask.data[i] <= 0.5 {
                    *pixel = image::Rgb([255, 0, 255]);
                } else if b.mask.data[i] > 0.5 {
                    pixel.0 = pixel.0.map(|v| v / 2 + 64);
                }
            }
            marked.save(format!("{out}_shadows.png"))?;
        }
    }
    println!(
        "{count} frames: foreground {:.3}% of the pixels, {:.3}% with the shadow cue; {changed} pixels carve otherwise",
        100.0 * sum_plain / f64::from(count),
        100.0 * sum_shadows / f64::from(count)
    );
    Ok(())
}
