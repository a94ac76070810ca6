//! `dynview import` and `dynview export-colmap`: event poses from calibrations (COLMAP,
//! Qualisys, Middlebury) and to COLMAP models.

use std::path::PathBuf;

use anyhow::Context;
use dynview_core::scene::{ScenePackage, encode_frame};
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
    /// Also write the package's frames as the images the model names, `<camera>/<t:05>.<ext>`
    /// in this folder: an image package's files as they are, a video package's frames as JPEG
    /// (at the packages' JPEG quality). A video package writes them to `OUT/images` when this
    /// is not given.
    #[arg(long)]
    images: Option<PathBuf>,
}

/// Runs `dynview export-colmap`: one COLMAP camera per camera, one image per registered frame,
/// no points.
pub fn run_export(args: ExportArgs) -> anyhow::Result<()> {
    let source = &args.source;
    let (poses, package) = if source.is_file() {
        anyhow::ensure!(args.images.is_none(), "--images needs a scene package; {} is a poses file", source.display());
        (EventPoses::read(source)?, None)
    } else {
        let package = ScenePackage::open(source).with_context(|| format!("opening scene package {}", source.display()))?;
        (EventPoses::from_manifest(package.manifest()), Some(package))
    };
    // Where the frames are to be written: checked before anything is.
    let write_to = package
        .as_ref()
        .and_then(|p| args.images.clone().or_else(|| p.manifest().frame_format.is_video().then(|| args.out.join("images"))));
    if let Some(dir) = &write_to {
        check_images_dir(dir, &poses)?;
    }
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
    let images = match (&package, write_to) {
        (Some(package), Some(dir)) => {
            write_frames(package, &poses, &dir)?;
            Some(dir)
        }
        (Some(_), None) => Some(source.join(dynview_core::scene::manifest::FRAMES_DIR)),
        (None, _) => None,
    };
    if let Some(dir) = images {
        println!("its images are in {} (COLMAP's --image_path)", dir.display());
    }
    Ok(())
}

/// Refuses an images folder that holds anything but folders named after `poses`' cameras (an
/// earlier export, whose files are replaced).
fn check_images_dir(dir: &std::path::Path, poses: &EventPoses) -> anyhow::Result<()> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Ok(()) };
    for entry in entries {
        let entry = entry.with_context(|| format!("listing {}", dir.display()))?;
        let name = entry.file_name();
        let ours = entry.path().is_dir() && poses.cameras.iter().any(|c| name.to_str() == Some(c.name.as_str()));
        anyhow::ensure!(
            ours,
            "{}: holds {:?}, which is not a camera's folder of an earlier export; refusing to write images into it",
            dir.display(),
            name
        );
    }
    Ok(())
}

/// Writes every frame of `package` into `dir` under the name `poses` gives it: an image
/// package's files copied, a video package's frames decoded and encoded as JPEG.
fn write_frames(package: &ScenePackage, poses: &EventPoses, dir: &std::path::Path) -> anyhow::Result<()> {
    let bars = crate::progress::StageBars::new();
    let total = poses.frame_count() as u64;
    let mut done = 0;
    for (c, camera) in poses.cameras.iter().enumerate() {
        let camera_dir = dir.join(&camera.name);
        std::fs::create_dir_all(&camera_dir).with_context(|| format!("creating {}", camera_dir.display()))?;
        for (t, frame) in camera.frames.iter().enumerate() {
            let path = camera_dir.join(&frame.file);
            let bytes = if package.manifest().frame_format.is_video() {
                let rgb = package.read_frame(c, t as u32)?.to_rgb8();
                encode_frame(&rgb, EventPoses::image_format_of(package.manifest()), &path.display().to_string())?
            } else {
                let from = package.frame_path(c, t as u32)?;
                std::fs::read(&from).with_context(|| format!("reading {}", from.display()))?
            };
            dynview_core::fsutil::write_atomic(&path, &bytes).with_context(|| format!("writing {}", path.display()))?;
            done += 1;
            bars.update("images", done, total);
        }
    }
    bars.finish();
    Ok(())
}
