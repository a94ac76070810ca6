//! A human-readable summary of a package (`dynview info`).

use std::fmt;

use super::cloud::CloudIndex;
use super::manifest::{Bounds, Manifest};

/// One camera line of the summary.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraSummary {
    /// Camera name.
    pub name: String,
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// Focal length x in pixels.
    pub fx: f64,
    /// Path length of the camera centre over the event, in scene units.
    pub path_length: f64,
    /// The largest change its color balance makes to a color, in 8-bit code values (`None`:
    /// no color balance).
    pub color_change: Option<f32>,
}

/// What `dynview info` prints.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneSummary {
    /// Scene name.
    pub name: String,
    /// Frames per second.
    pub fps: f64,
    /// Number of time steps.
    pub time_step_count: u32,
    /// Per-camera lines.
    pub cameras: Vec<CameraSummary>,
    /// Points in each time step's cloud.
    pub points_per_step: Vec<u32>,
    /// Scene bounds.
    pub bounds: Bounds,
    /// Total size of the package's files in bytes.
    pub size_on_disk_bytes: u64,
}

impl SceneSummary {
    /// Builds the summary from a validated manifest and clouds index.
    pub fn new(manifest: &Manifest, index: &CloudIndex, size_on_disk_bytes: u64) -> Self {
        let cameras = manifest
            .cameras
            .iter()
            .map(|c| {
                let centres: Vec<_> = c.poses.iter().map(|p| p.camera_from_world().camera_center_world()).collect();
                CameraSummary {
                    name: c.name.clone(),
                    width: c.width,
                    height: c.height,
                    fx: c.intrinsics.fx,
                    // A fold from +0: an empty sum of floats is -0, which prints as "-0.000".
                    path_length: centres.windows(2).map(|w| (w[1] - w[0]).length()).fold(0.0, |a, b| a + b),
                    color_change: c.color_balance.map(|b| 255.0 * b.largest_change()),
                }
            })
            .collect();
        Self {
            name: manifest.name.clone(),
            fps: manifest.fps,
            time_step_count: manifest.time_step_count,
            cameras,
            points_per_step: index.steps.iter().map(|s| s.point_count).collect(),
            bounds: manifest.bounds,
            size_on_disk_bytes,
        }
    }
}

impl fmt::Display for SceneSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let total: u64 = self.points_per_step.iter().map(|&n| u64::from(n)).sum();
        let min = self.points_per_step.iter().min().copied().unwrap_or(0);
        let max = self.points_per_step.iter().max().copied().unwrap_or(0);
        let mean = total as f64 / self.points_per_step.len().max(1) as f64;
        writeln!(f, "scene       {}", self.name)?;
        writeln!(f, "time steps  {} at {} fps ({:.2} s)", self.time_step_count, self.fps, f64::from(self.time_step_count) / self.fps)?;
        writeln!(f, "cameras     {}", self.cameras.len())?;
        for c in &self.cameras {
            write!(f, "  {:<16} {}x{}  fx {:.1} px  path {:.3}", c.name, c.width, c.height, c.fx, c.path_length)?;
            match c.color_change {
                Some(change) => writeln!(f, "  colors balanced (up to {change:.0} code values)")?,
                None => writeln!(f)?,
            }
        }
        writeln!(f, "points      {total} in all; per step min {min}, mean {mean:.0}, max {max}")?;
        let b = &self.bounds;
        writeln!(
            f,
            "bounds      [{:.3}, {:.3}, {:.3}] .. [{:.3}, {:.3}, {:.3}]",
            b.min[0], b.min[1], b.min[2], b.max[0], b.max[1], b.max[2]
        )?;
        write!(f, "size        {:.2} MiB on disk", self.size_on_disk_bytes as f64 / (1024.0 * 1024.0))
    }
}
