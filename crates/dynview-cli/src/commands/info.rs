//! `dynview info`.

use std::path::PathBuf;

use anyhow::Context;
use dynview_core::scene::ScenePackage;

use crate::progress::StageBars;

/// Arguments of `dynview info`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The scene package folder.
    scene: PathBuf,
    /// Only read scene.json and the clouds index (skip checking every cloud and frame).
    #[arg(long)]
    quick: bool,
}

/// Runs `dynview info`: validates the package (fully unless `--quick`) and prints a summary.
pub fn run(args: Args) -> anyhow::Result<()> {
    let package = ScenePackage::open(&args.scene).with_context(|| format!("opening scene package {}", args.scene.display()))?;
    if !args.quick {
        let bars = StageBars::new();
        package
            .verify(|done, total| bars.update("verify", done, total))
            .with_context(|| format!("checking scene package {}", args.scene.display()))?;
        bars.finish();
    }
    println!("{}", package.summary()?);
    Ok(())
}
