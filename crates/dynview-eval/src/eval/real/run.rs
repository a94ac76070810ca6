//! What a run of `eval-real` is asked and what it finds for one held-out camera: the command
//! line's [`Options`], the methods rendered, a camera's [`CameraResult`] and the names of the
//! files a run writes. The evaluation (`real.rs`) and the report (`report.rs`) both use them.

use std::path::PathBuf;

use dynview_core::render::{Method, RenderParams};

use super::scores::Score;
use crate::datasets::real_captures::RealCapture;
use crate::paths::results_dir;
use crate::runs::prep::prep_args_suffix;

/// Methods rendered, the full method first.
pub(super) const METHODS: [Method; 4] = [Method::Full, Method::NoTemporal, Method::Blend, Method::BestView];
/// Options of `dynview-eval eval-real` (`cargo xtask eval --real`).
#[derive(Debug, clap::Args)]
pub struct Options {
    /// The captures to evaluate (all when not given); the report keeps the last results of
    /// the others.
    #[arg(long, value_enum)]
    pub capture: Vec<RealCapture>,
    /// Frames of each camera used, from the first (all of them when not given: 75 on the
    /// Panoptic arcs, 100 on Pose2Sim).
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..))]
    pub frames: Option<u32>,
    /// A camera to leave out (repeatable; every interior camera of each capture when not
    /// given). The captures without any of them are skipped.
    #[arg(long = "held-out", value_name = "CAMERA")]
    pub held_out: Vec<String>,
    /// Redo the prep runs even when their packages exist.
    #[arg(long)]
    pub fresh: bool,
    /// An extra argument for every `dynview prep` run (repeatable; e.g. `--prep-arg=--no-static`
    /// to compare). The runs then work in a folder of their own, named after the arguments.
    #[arg(long = "prep-arg", allow_hyphen_values = true)]
    pub prep_args: Vec<String>,
    /// Renderer parameters that differ from the defaults, as JSON or a JSON file (the fields of
    /// `RenderParams`, e.g. `--params '{"lambda_plane": 0}'` to compare).
    #[arg(long, value_parser = parse_params)]
    pub params: Option<RenderParams>,
    /// Folder of the written results.
    #[arg(long, default_value_os_t = results_dir())]
    pub out: PathBuf,
    /// Make the Panoptic arcs unsynchronized (each camera cut at its own start, one a 15 fps
    /// video) and report the offsets prep finds and the held-out PSNR against the synchronized
    /// run (`unsync.md`) instead of the leave-one-out tables.
    #[arg(long)]
    pub unsync: bool,
    /// Prepare the Panoptic arcs' cameras also without their calibration, from our own
    /// structure from motion, and compare the held-out camera rendered from each package, its
    /// pose as mapped and registered against the package (`own_poses.md`), instead of the
    /// leave-one-out tables.
    #[arg(long, conflicts_with = "unsync")]
    pub own_poses: bool,
}

/// Renderer parameters from JSON, or from a JSON file when `json` names one (as `eval --params`).
pub(super) fn parse_params(json: &str) -> Result<RenderParams, String> {
    let text = if std::path::Path::new(json).is_file() {
        std::fs::read_to_string(json).map_err(|e| format!("{json}: {e}"))?
    } else {
        json.to_string()
    };
    let params: RenderParams = serde_json::from_str(&text).map_err(|e| format!("renderer parameters: {e}"))?;
    params.validate().map_err(|e| e.to_string())?;
    Ok(params)
}

/// Scores of one held-out camera.
pub(super) struct CameraResult {
    pub(super) name: String,
    /// The methods' scores in [`METHODS`] order, then the plane view's and the floor's.
    pub(super) scores: Vec<Score>,
    /// The input camera the floor shows (the best ranked at the middle time step).
    pub(super) nearest: String,
    pub(super) prep_secs: f64,
    pub(super) ms_per_frame: f64,
    /// Mean points per time step of the package of the other cameras.
    pub(super) points_per_step: f64,
    /// Median relative depth error (%) of the full method and of the blend's push-pull depth
    /// against the reference package's points as the held-out camera sees them.
    pub(super) depth_error_pct: [f64; 2],
    /// Mean share of the frame's pixels that move ([`super::scores::moving_mask`]), %.
    pub(super) moving_pct: f64,
}

/// The work folder under the workspace: `target/eval/real`, or one named after the extra prep
/// arguments (so that runs with different arguments keep their own prepared steps).
pub(super) fn work_folder(prep_args: &[String]) -> String {
    format!("target/eval/real{}", prep_args_suffix(prep_args))
}

/// The file name of a held-out camera's strip.
pub(super) fn strip_name(capture: RealCapture, camera: &str) -> String {
    format!("real_strip_{}_{camera}.png", capture.label())
}

/// The file name of a capture's orbit strip ([`super::orbit`]).
pub(super) fn orbit_strip_name(capture: RealCapture) -> String {
    format!("orbit_strip_{}.png", capture.label())
}
