//! `dynview import-colmap` and `dynview export-colmap`: event poses from and to COLMAP models.

use std::path::PathBuf;

use anyhow::Context;
use dynview_core::colmap::{ColmapFormat, ColmapModel};
use dynview_core::poses::EventPoses;
use dynview_core::scene::ScenePackage;

/// Arguments of `dynview import-colmap`.
#[derive(clap::Args, Debug)]
pub struct ImportArgs {
    /// The COLMAP model folder: cameras, images and points3D as .bin or .txt (detected; binary
    /// wins when both are there). Image names must be `<camera>/<frame file>`.
    model_dir: PathBuf,
    /// The poses file to write (poses.json).
    #[arg(long)]
    out: PathBuf,
}

/// Runs `dynview import-colmap`: reads the model, converts it and writes `poses.json`.
pub fn run_import(args: ImportArgs) -> anyhow::Result<()> {
    let dir = &args.model_dir;
    let format = ColmapModel::detect_format(dir)?;
    let model = ColmapModel::read_dir(dir).with_context(|| format!("reading the COLMAP model in {}", dir.display()))?;
    let poses = EventPoses::from_colmap(&model).with_context(|| format!("converting the COLMAP model in {}", dir.display()))?;
    poses.write(&args.out)?;
    println!(
        "read {format} COLMAP model {}: {} cameras, {} images, {} points",
        dir.display(),
        model.cameras.len(),
        model.images.len(),
        model.points3d.len()
    );
    println!(
        "wrote {}: {} cameras, {} frames, {} registered",
        args.out.display(),
        poses.cameras.len(),
        poses.frame_count(),
        poses.registered_frame_count()
    );
    Ok(())
}

/// Arguments of `dynview export-colmap`.
#[derive(clap::Args, Debug)]
pub struct ExportArgs {
    /// A scene package folder (frames named `<t:05>.<ext>`), or a poses.json file.
    source: PathBuf,
    /// The COLMAP model folder to write: created if missing; an earlier model there is
    /// replaced; any other non-empty folder is refused.
    #[arg(long)]
    out: PathBuf,
    /// Write cameras.bin, images.bin, points3D.bin instead of the .txt files.
    #[arg(long)]
    binary: bool,
}

/// Runs `dynview export-colmap`: one COLMAP camera per camera, one image per registered frame,
/// no points.
pub fn run_export(args: ExportArgs) -> anyhow::Result<()> {
    let source = &args.source;
    let poses = if source.is_file() {
        EventPoses::read(source)?
    } else {
        let package = ScenePackage::open(source).with_context(|| format!("opening scene package {}", source.display()))?;
        EventPoses::from_manifest(package.manifest())
    };
    let model = poses.to_colmap();
    let format = if args.binary { ColmapFormat::Binary } else { ColmapFormat::Text };
    model.write_dir(&args.out, format).with_context(|| format!("writing the COLMAP model to {}", args.out.display()))?;
    println!(
        "wrote {format} COLMAP model {}: {} cameras, {} images ({} of {} frames registered)",
        args.out.display(),
        model.cameras.len(),
        model.images.len(),
        poses.registered_frame_count(),
        poses.frame_count()
    );
    Ok(())
}
