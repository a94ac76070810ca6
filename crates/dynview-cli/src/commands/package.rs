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

/// Arguments of `dynview repack`.
#[derive(clap::Args, Debug)]
pub struct RepackArgs {
    /// The scene package folder to read (format v1 or v2).
    scene: PathBuf,
    /// The package folder to write (replaced only when the new package is complete; not the
    /// one read).
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    frames_as: crate::commands::frames::FrameArgs,
}

/// Runs `dynview repack`.
pub fn run_repack(args: RepackArgs) -> anyhow::Result<()> {
    let package = ScenePackage::open(&args.scene).with_context(|| format!("opening scene package {}", args.scene.display()))?;
    if args.out.canonicalize().ok().is_some_and(|out| args.scene.canonicalize().ok() == Some(out)) {
        bail!("--out {}: that is the package being read; write somewhere else, then move it", args.out.display());
    }
    let bars = crate::progress::StageBars::new();
    let result =
        dynview_core::scene::repack::repack(&package, &args.out, args.frames_as.video(), args.frames_as.format_v1(), |done, total| {
            bars.update("repack", done, total)
        });
    bars.finish();
    let manifest = result.with_context(|| format!("repacking {} into {}", args.scene.display(), args.out.display()))?;
    let before = package.size_on_disk()?;
    let after = ScenePackage::open(&args.out)?.size_on_disk()?;
    println!(
        "wrote {} (format v{}, {:?} frames): {:.2} MB, was {:.2} MB",
        args.out.display(),
        manifest.version,
        manifest.frame_format,
        after as f64 / 1e6,
        before as f64 / 1e6
    );
    Ok(())
}
