//! `cargo xtask bench prep`: `dynview prep` (release) end to end on a 6-camera, 100-frame,
//! 960x540 hand-held synthetic event's videos: wall time, per-stage times from `report.json`,
//! package size, cloud sizes and pose accuracy against the ground truth. Written to
//! `docs/results/prep.md`. The event is made once under `target/bench/prep/event`; prep always
//! starts from scratch (a benchmark of reused stages would measure nothing).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, bail};
use dynview_core::scene::ScenePackage;
use dynview_synth::SynthConfig;

use crate::paths::{results_dir, workspace_root};
use crate::runs::prep::{align_packages, cloud_point_counts, run_prep, stage_seconds, stage_table};
use crate::runs::programs::dynview_binary;

/// The event of the benchmark.
fn event_config() -> SynthConfig {
    SynthConfig { cameras: 6, frames: 100, width: 960, height: 540, handheld: true, videos: true, ..SynthConfig::default() }
}

/// Issue 7's target for the whole prep on this event, seconds.
const TARGET_SECS: f64 = 600.0;

/// The 1-minute load average (other work on the machine skews the times).
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg").ok().and_then(|s| s.split_whitespace().next().map(str::to_owned)).unwrap_or_else(|| "?".into())
}

/// Options of `dynview-eval bench-prep` (`cargo xtask bench prep`).
#[derive(Debug, clap::Args)]
pub struct Options {
    /// Folder of the written `prep.md`.
    #[arg(long, default_value_os_t = results_dir())]
    pub out: PathBuf,
    /// Make the event (once) and stop.
    #[arg(long)]
    pub event_only: bool,
}

/// The benchmark: the whole `dynview prep` on the event's videos, timed and scored.
pub fn run(options: Options) -> anyhow::Result<()> {
    let Options { out: out_dir, event_only } = options;
    let root = workspace_root().join("target/bench/prep");
    let event = root.join("event");
    let config = event_config();
    if !event.join(dynview_synth::SYNTH_MARKER).is_file() || !event.join("videos").is_dir() {
        println!("==> making the benchmark event in {} (6 hand-held cameras, 100 frames of 960x540, videos) ...", event.display());
        let progress = |stage: &str, done: u64, total: u64| {
            if done == total || done.is_multiple_of((total / 4).max(1)) {
                println!("  {stage}: {done} / {total}");
            }
        };
        let report = dynview_synth::generate(&config, &event, &progress).with_context(|| format!("generating {}", event.display()))?;
        if !report.videos_written {
            bail!("the benchmark needs the event's videos: install ffmpeg");
        }
    }
    if event_only {
        println!("event ready in {}", event.display());
        return Ok(());
    }
    let dynview = dynview_binary()?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let load_before = load_average();
    let run = run_prep(&dynview, &event.join("videos"), &root.join("out"), &[], true)?;
    let load_after = load_average();
    let stages = stage_seconds(&run.out)?;
    let package = ScenePackage::open(run.scene_dir()).with_context(|| format!("opening {}", run.scene_dir().display()))?;
    let truth = ScenePackage::open(event.join("scene"))?;
    let accuracy = align_packages(&package, &truth)?;
    let (points, fewest, most) = cloud_point_counts(&package);
    let steps = package.time_step_count();

    let mut s = String::new();
    let _ = writeln!(s, "# `dynview prep` benchmark\n");
    let _ = writeln!(
        s,
        "Synthetic event: {} hand-held cameras, {} frames of {}x{} (`dynview synth`, seed {}), prep from its H.264 videos with default \
         options (release build, {cores} cores; 1-minute load average {load_before} before, {load_after} after: other work on the machine \
         shares the cores).\n",
        config.cameras, config.frames, config.width, config.height, config.seed
    );
    let verdict = if run.wall_secs <= TARGET_SECS { "met" } else { "not met" };
    let _ = writeln!(
        s,
        "**Total wall time: {:.0} s ({:.1} min)**; target ≤ {:.0} min: **{verdict}**.\n",
        run.wall_secs,
        run.wall_secs / 60.0,
        TARGET_SECS / 60.0
    );
    let _ = writeln!(s, "Stages (`report.json`):\n\n{}", stage_table(&stages));
    let _ = writeln!(s, "| output | value |\n| --- | ---: |");
    let _ = writeln!(s, "| package size | {:.1} MB |", package.size_on_disk()? as f64 / 1e6);
    let _ = writeln!(s, "| time steps | {steps} |");
    let _ = writeln!(s, "| points, all steps | {points} |");
    let _ = writeln!(s, "| points per step (mean, fewest, most) | {:.0}, {fewest}, {most} |", points as f64 / f64::from(steps.max(1)));
    let _ = writeln!(s, "| camera poses registered | {} of {} |", accuracy.registered, accuracy.ground_truth_images);
    let _ = writeln!(
        s,
        "| rotation error, median / max | {:.3} / {:.3} deg |",
        accuracy.rotation_error_median_deg, accuracy.rotation_error_max_deg
    );
    let _ = writeln!(
        s,
        "| centre error, median / max (after a similarity; % of the camera spread) | {:.3} / {:.3} % |",
        accuracy.center_error_median_fraction * 100.0,
        accuracy.center_error_max_fraction * 100.0
    );
    let _ =
        writeln!(s, "\nPose errors: every camera at every time step against the ground-truth package (`crate::align::evaluate_poses`).");
    let _ = writeln!(
        s,
        "\nReproduce: `cargo xtask bench prep` (event in `target/bench/prep/event`, made once; prep output in `target/bench/prep/out`)."
    );
    println!("\n{s}");
    std::fs::create_dir_all(&out_dir)?;
    let path = out_dir.join("prep.md");
    dynview_core::fsutil::write_atomic(&path, s.as_bytes())?;
    println!("wrote {}", path.display());
    Ok(())
}
