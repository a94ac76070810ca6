//! `dynview merge` (range outputs of `prep --frames` into one scene package) and
//! `dynview export-ply` (one time step's cloud for other tools).

use std::path::PathBuf;

use anyhow::{Context, bail};
use dynview_core::scene::{ScenePackage, encode_ply};

use crate::progress::StageBars;

/// Arguments of `dynview merge`.
#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// `prep` output folders of one event (the same pose stage), together holding every time
    /// step; when several hold a step, the first is used.
    #[arg(required = true)]
    outputs: Vec<PathBuf>,
    /// The scene package folder to write (replaced only when the new package is complete).
    #[arg(long)]
    out: PathBuf,
    /// The package's name (default: the --out folder's name).
    #[arg(long)]
    name: Option<String>,
}

/// Runs `dynview merge`.
pub fn run_merge(args: MergeArgs) -> anyhow::Result<()> {
    let name = args.name.clone().unwrap_or_else(|| args.out.file_name().map_or("event".into(), |n| n.to_string_lossy().into_owned()));
    let bars = StageBars::new();
    let result =
        dynview_sfm::export::export_package(&args.outputs, &args.out, &name, &|stage, done, total| bars.update(stage, done, total));
    bars.finish();
    let report = result.with_context(|| format!("dynview merge into {}", args.out.display()))?;
    for warning in &report.warnings {
        eprintln!("warning: {warning}");
    }
    println!(
        "wrote {} ({} cameras x {} time steps, {} points, {:.1} MB)",
        args.out.display(),
        report.cameras,
        report.time_steps,
        report.points,
        report.bytes as f64 / 1e6
    );
    Ok(())
}

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
