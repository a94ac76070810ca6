//! `dynview import` and `dynview export-colmap`: event poses from calibrations (COLMAP,
//! Qualisys, Middlebury) and to COLMAP models.

use std::path::PathBuf;

use anyhow::Context;
use dynview_core::scene::ScenePackage;
use dynview_interchange::colmap::{ColmapFormat, ColmapModel};
use dynview_interchange::import::{CalibrationFormat, read_event_poses};
use dynview_interchange::poses::EventPoses;

/// Arguments of `dynview import`.
#[derive(clap::Args, Debug)]
pub struct ImportArgs {
    /// The calibration: a COLMAP model folder (cameras, images and points3D as .bin or .txt;
    /// image names `<camera>/<frame file>`), a Qualisys `.qca.txt`, a Middlebury `*_par.txt`
    /// (the images beside it give the sizes) or a `poses.json`; the format is detected.
    source: PathBuf,
    /// The poses file to write (poses.json).
    #[arg(long)]
    out: PathBuf,
}

/// Runs `dynview import`: reads the calibration, converts it and writes `poses.json`.
pub fn run_import(args: ImportArgs) -> anyhow::Result<()> {
    let source = &args.source;
    let format = CalibrationFormat::detect(source)?;
    let poses = read_event_poses(source).with_context(|| format!("importing {}", source.display()))?;
    poses.write(&args.out)?;
    if format == CalibrationFormat::Colmap {
        let model = ColmapModel::read_dir(source)?;
        println!(
            "read {} COLMAP model {}: {} cameras, {} images, {} points",
            ColmapModel::detect_format(source)?,
            source.display(),
            model.cameras.len(),
            model.images.len(),
            model.points3d.len()
        );
    } else {
        println!("read {} {}", format.name(), source.display());
    }
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
