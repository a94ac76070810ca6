//! Times the plates' static mask (`dynview_core::render::plates::static_mask`) of a prepared
//! package's middle time step, seen by its second camera at 640x360 and 1920x1080: median of
//! 5 runs, and how many of its pixels are not static. `cargo run --release -p dynview-eval
//! --example static_mask_timing -- SCENE_DIR [PARAMS_JSON]` (default: arc 1's package of all
//! cameras, `target/eval/real/panoptic/all75/scene`, which `cargo xtask eval --real --capture
//! panoptic` writes; the default render parameters, or those the JSON changes, e.g.
//! `'{"plate_static_reach_px": 6}'`).

use std::time::Instant;

use anyhow::Context;
use dynview_core::render::{RenderParams, plates};
use dynview_core::scene::ScenePackage;

fn main() -> anyhow::Result<()> {
    let dir = std::env::args().nth(1).unwrap_or_else(|| "target/eval/real/panoptic/all75/scene".into());
    let package = ScenePackage::open(&dir).with_context(|| format!("opening {dir}"))?;
    let step = package.time_step_count() / 2;
    let params: RenderParams = match std::env::args().nth(2) {
        Some(json) => serde_json::from_str(&json).context("the second argument: render parameters as JSON")?,
        None => RenderParams::default(),
    };
    let inputs = package.time_step_inputs(step, params.levels)?;
    let camera = package.camera(1.min(package.manifest().cameras.len() - 1), step)?;
    for (width, height) in [(640, 360), (1920, 1080)] {
        let camera = camera.resized(width, height);
        let mut ms = Vec::new();
        let (mut masked, mut size) = (0, (0, 0));
        for _ in 0..5 {
            let start = Instant::now();
            let mask = plates::static_mask(&params, &inputs.cloud, inputs.static_points, &camera).context("the package has no plates")?;
            ms.push(start.elapsed().as_secs_f64() * 1000.0);
            masked = mask.data.iter().filter(|&&v| v == 0.0).count();
            size = (mask.width, mask.height);
        }
        ms.sort_by(f64::total_cmp);
        println!(
            "{width}x{height}: {:.1} ms (median of 5); {} points, {} static; mask {}x{}, {masked} pixels not static",
            ms[2],
            inputs.cloud.len(),
            inputs.static_points,
            size.0,
            size.1
        );
    }
    Ok(())
}
