//! `dynview export-ply`: one time step's cloud for other tools.

use std::path::PathBuf;

use anyhow::{Context, bail};
use dynview_core::scene::ScenePackage;
use dynview_interchange::ply::encode_ply;

/// Arguments of `dynview export-ply`.
#[derive(clap::Args, Debug)]
pub struct PlyArgs {
    /// The scene package folder.
    scene: PathBuf,
    /// The time step (from 0).
    #[arg(long)]
    frame: u32,
    /// The PLY file to write (default: `<scene>/../<name>_t<frame>.ply`).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Runs `dynview export-ply`.
pub fn run_ply(args: PlyArgs) -> anyhow::Result<()> {
    let package = ScenePackage::open(&args.scene).with_context(|| format!("opening scene package {}", args.scene.display()))?;
    let steps = package.time_step_count();
    if args.frame >= steps {
        bail!("--frame {}: the package has time steps 0..{}", args.frame, steps - 1);
    }
    let cloud = package.read_cloud(args.frame)?;
    let out = args.out.unwrap_or_else(|| {
        let name = args.scene.file_name().map_or("scene".into(), |n| n.to_string_lossy().into_owned());
        args.scene.with_file_name(format!("{name}_t{:05}.ply", args.frame))
    });
    let comment = format!("dynview scene {} time step {}", package.manifest().name, args.frame);
    dynview_core::fsutil::write_atomic(&out, &encode_ply(&cloud, &comment)).with_context(|| format!("writing {}", out.display()))?;
    println!("wrote {} ({} points)", out.display(), cloud.len());
    Ok(())
}
