//! `dynview merge`: range outputs of `prep --frames` into one scene package (with the `prep`
//! feature).

use std::path::PathBuf;

use anyhow::Context;

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
    /// Each time step keeps only its own points (no static points accumulated across time).
    #[arg(long)]
    no_static: bool,
    /// No static cloud grown by stereo on the background plates of the cameras that stand
    /// still (by default it replaces the static points found across time, which seed it).
    #[arg(long)]
    no_plates: bool,
    /// No points from the visual hull of what moves (by default, with plates of four cameras
    /// or more, rays through each camera's foreground give moving things without stereo points
    /// a depth where they enter the space every other camera's foreground allows).
    #[arg(long)]
    no_hull: bool,
    /// No plates made per step for the cameras without one of their own (hand-held ones): by
    /// default their frames a few steps around each step, carried through the scene's depth,
    /// give them a plate, and their foregrounds join the visual hull (docs/results/moving.md).
    #[arg(long, conflicts_with = "no_hull")]
    no_moving_plates: bool,
    /// Keep the steps' own points that float in front of the static scene where two or more
    /// still cameras see their background plate (by default they are dropped: nothing stands
    /// where a camera looking through it sees the wall behind).
    #[arg(long)]
    no_free_space: bool,
    /// Store every camera's frames as they are: no color balance between the cameras (by
    /// default each camera's colors are mapped to the response the cameras share, estimated
    /// from the points they see in common).
    #[arg(long)]
    no_color_balance: bool,
    #[command(flatten)]
    frames_as: crate::commands::frames::FrameArgs,
}

/// Runs `dynview merge`.
pub fn run_merge(args: MergeArgs) -> anyhow::Result<()> {
    let name = args.name.clone().unwrap_or_else(|| args.out.file_name().map_or("event".into(), |n| n.to_string_lossy().into_owned()));
    let bars = StageBars::new();
    let options = dynview_sfm::pipeline::export::PackageOptions {
        static_cloud: (!args.no_static).then(dynview_sfm::dense::static_cloud::StaticOptions::default),
        plates: (!args.no_plates).then(dynview_sfm::dense::plate_cloud::PlateCloudOptions::default),
        hull: (!args.no_hull).then(dynview_sfm::dense::hull::HullOptions::default),
        free_space: (!args.no_free_space).then(dynview_sfm::dense::free_space::FreeSpaceOptions::default),
        moving_plates: !args.no_moving_plates,
        video: args.frames_as.video(),
        format_v1: args.frames_as.format_v1(),
        color_balance: !args.no_color_balance,
    };
    let result = dynview_sfm::pipeline::export::export_package(&args.outputs, &args.out, &name, &options, &|stage, done, total| {
        bars.update(stage, done, total)
    });
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
