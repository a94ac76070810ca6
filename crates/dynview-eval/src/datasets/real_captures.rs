//! The real captures of `../shared/data` that `eval-real` judges the renderer on, each as
//! `dynview prep` input: image folders of its first frames, and calibrated poses for any subset of
//! its cameras. The two Panoptic arcs are disjoint sets of cameras of one sequence: a change
//! judged on one is checked on the other.

use std::path::Path;

use anyhow::Context;

use crate::datasets::panoptic::PanopticArc;
use crate::datasets::{panoptic, pose2sim};

/// Working width of prep's frames for the Panoptic arcs: their full 640x360.
const PANOPTIC_WORKING_WIDTH_PX: u32 = 640;

/// A real capture of `../shared/data`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RealCapture {
    /// Panoptic's basketball arc: 8 cameras on an arc, neighbours 5-25 degrees apart (the
    /// paper's regime); cam11, cam08 and cam27 are left out in turn.
    Panoptic,
    /// Panoptic's second basketball arc: 10 other cameras, neighbours 1-36 degrees apart (two
    /// wide gaps); cam09, cam04 and cam07 are left out in turn.
    PanopticArc2,
    /// Pose2Sim's lab capture: 4 portrait cameras about 90 degrees apart (the hard,
    /// wide-baseline case); every camera is left out in turn.
    Pose2sim,
}

impl RealCapture {
    /// Every capture, in report order.
    pub const ALL: [RealCapture; 3] = [RealCapture::Panoptic, RealCapture::PanopticArc2, RealCapture::Pose2sim];

    /// The Panoptic arc the capture is, if it is one.
    pub(crate) fn panoptic_arc(self) -> Option<PanopticArc> {
        match self {
            Self::Panoptic => Some(PanopticArc::First),
            Self::PanopticArc2 => Some(PanopticArc::Second),
            Self::Pose2sim => None,
        }
    }

    /// Short name for folders, files and the command line.
    pub fn label(self) -> &'static str {
        match self {
            Self::Panoptic => "panoptic",
            Self::PanopticArc2 => "panoptic-arc2",
            Self::Pose2sim => "pose2sim",
        }
    }

    /// One paragraph on what the capture is, for the report.
    pub fn description(self) -> &'static str {
        match self {
            Self::Panoptic => {
                "CMU Panoptic's basketball sequence as Dynamic 3D Gaussians prepared it (`../shared/data/panoptic-basketball-arc`): \
                 8 calibrated cameras on an arc of about 120 degrees, neighbours 5-25 degrees apart, 640x360, two people passing a ball. \
                 Each interior camera (cam11, cam08, cam27) is left out in turn; the other seven are prepared with their calibration."
            }
            Self::PanopticArc2 => {
                "The same Panoptic basketball sequence seen by a second, disjoint arc of cameras \
                 (`../shared/data/panoptic-basketball-arc2`): 10 calibrated cameras over about 140 degrees, neighbours 1-36 degrees \
                 apart with two wide gaps (cam03 to cam07, cam07 to cam02), 640x360. Each interior camera (cam09, cam04, cam07) is \
                 left out in turn; the other nine are prepared with their calibration."
            }
            Self::Pose2sim => {
                "Pose2Sim's multi-person lab capture (`../shared/data/pose2sim-multiperson`): 4 synchronized portrait cameras about 90 \
                 degrees apart, 1088x1920, people on a treadmill. Every camera is left out in turn; the other three are prepared with \
                 the Qualisys calibration (distortion included)."
            }
        }
    }

    /// Every camera's name.
    pub fn cameras(self) -> anyhow::Result<Vec<String>> {
        Ok(match self.panoptic_arc() {
            Some(arc) => panoptic::calibration(arc, None)?.cameras.into_iter().map(|c| c.name).collect(),
            None => pose2sim::calibration()?.into_iter().map(|c| c.serial).collect(),
        })
    }

    /// The cameras left out in turn by default.
    pub fn held_out(self) -> anyhow::Result<Vec<String>> {
        Ok(match self.panoptic_arc() {
            Some(arc) => arc.held_out().iter().map(|c| c.to_string()).collect(),
            None => self.cameras()?,
        })
    }

    /// Frames of every camera in the capture.
    pub fn frame_count(self) -> u32 {
        match self.panoptic_arc() {
            Some(_) => panoptic::FRAMES,
            None => pose2sim::FRAMES,
        }
    }

    /// The width prep works at (`--working-width`).
    pub fn working_width_px(self) -> u32 {
        match self.panoptic_arc() {
            Some(_) => PANOPTIC_WORKING_WIDTH_PX,
            None => pose2sim::WORKING_WIDTH_PX,
        }
    }

    /// Puts the first `frames` frames of every camera into `out/<camera>/` (kept when there).
    pub fn write_frames(self, out: &Path, frames: u32) -> anyhow::Result<()> {
        match self.panoptic_arc() {
            Some(arc) => panoptic::copy_first_frames(arc, out, frames),
            None => pose2sim::extract_first_frames(out, frames),
        }
    }

    /// Writes the calibrated poses of the cameras in `keep` (all when `None`) as `poses.json`.
    pub fn write_poses(self, path: &Path, keep: Option<&[&str]>) -> anyhow::Result<()> {
        match self.panoptic_arc() {
            Some(arc) => {
                if let Some(parent) = path.parent() {
                    std::fs::create_dir_all(parent).with_context(|| format!("cannot create {}", parent.display()))?;
                }
                panoptic::calibration(arc, keep)?.write(path).with_context(|| format!("writing {}", path.display()))
            }
            None => pose2sim::write_calibrated_poses(path, keep),
        }
    }
}
