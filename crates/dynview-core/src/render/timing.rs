//! Per-level, per-stage timings of a render, measured with a caller-supplied clock (the core
//! has no clock of its own: `std::time::Instant` does not exist in the browser's wasm32).

use serde::{Deserialize, Serialize};

/// The stages of a render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Projecting the sparse cloud and the previous frame.
    Sparse,
    /// Push-pull fills and pyramid resampling.
    PushPull,
    /// Backward warps of the input views.
    Warp,
    /// Visibility by scatter.
    Visibility,
    /// The weights and the assembly of the linear systems.
    Weights,
    /// Depth sweeps.
    DepthSolve,
    /// Color sweeps.
    ColorSolve,
}

/// Milliseconds spent per stage at one pyramid level.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LevelTimings {
    /// Pyramid level (0 = finest).
    pub level: usize,
    /// Width at this level.
    pub width: usize,
    /// Height at this level.
    pub height: usize,
    /// Sparse projection and temporal warp.
    pub sparse_ms: f64,
    /// Push-pull and resampling.
    pub pushpull_ms: f64,
    /// Warps.
    pub warp_ms: f64,
    /// Visibility.
    pub visibility_ms: f64,
    /// Weights and system assembly.
    pub weights_ms: f64,
    /// Depth solve.
    pub depth_solve_ms: f64,
    /// Color solve.
    pub color_solve_ms: f64,
}

impl LevelTimings {
    /// Sum of the stages.
    pub fn total_ms(&self) -> f64 {
        self.sparse_ms + self.pushpull_ms + self.warp_ms + self.visibility_ms + self.weights_ms + self.depth_solve_ms + self.color_solve_ms
    }

    fn slot(&mut self, stage: Stage) -> &mut f64 {
        match stage {
            Stage::Sparse => &mut self.sparse_ms,
            Stage::PushPull => &mut self.pushpull_ms,
            Stage::Warp => &mut self.warp_ms,
            Stage::Visibility => &mut self.visibility_ms,
            Stage::Weights => &mut self.weights_ms,
            Stage::DepthSolve => &mut self.depth_solve_ms,
            Stage::ColorSolve => &mut self.color_solve_ms,
        }
    }
}

/// Timings of a whole render.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// One entry per level, in the order rendered (coarsest first).
    pub levels: Vec<LevelTimings>,
    /// Sum over levels.
    pub total_ms: f64,
}

/// Accumulates the time since the last lap into a stage.
pub(crate) struct Stopwatch<'a> {
    clock: Option<&'a dyn Fn() -> f64>,
    last: f64,
    current: LevelTimings,
}

impl<'a> Stopwatch<'a> {
    pub(crate) fn new(clock: Option<&'a dyn Fn() -> f64>) -> Self {
        let last = clock.map_or(0.0, |c| c());
        Self { clock, last, current: LevelTimings::default() }
    }

    /// Charges the time since the previous lap to `stage`.
    pub(crate) fn lap(&mut self, stage: Stage) {
        if let Some(clock) = self.clock {
            let now = clock();
            *self.current.slot(stage) += now - self.last;
            self.last = now;
        }
    }

    /// Closes the current level.
    pub(crate) fn finish_level(&mut self, level: usize, width: usize, height: usize) -> LevelTimings {
        let mut done = std::mem::take(&mut self.current);
        done.level = level;
        done.width = width;
        done.height = height;
        done
    }
}
