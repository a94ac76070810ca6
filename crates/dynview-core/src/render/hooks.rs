//! What a caller hooks into a render: a clock for timings, a per-level callback (progressive
//! display, cancel), and traces of the linear solves.

use super::outputs::LevelPreview;

/// Optional hooks of a render: a clock for timings, a per-level callback that may cancel, and
/// a trace of every linear solve (for tests and diagnostics; it costs an energy evaluation
/// per sweep).
#[derive(Default)]
pub struct RenderHooks<'a> {
    /// Milliseconds since an arbitrary origin; enables timings.
    pub clock: Option<&'a dyn Fn() -> f64>,
    /// Called after each level; returning `false` cancels the render.
    pub on_level: Option<&'a mut dyn FnMut(LevelPreview) -> bool>,
    /// When set, every solve appends its trace here.
    pub solve_traces: Option<&'a mut Vec<SolveTrace>>,
}

/// Which energy a solve minimises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolveKind {
    /// `E_D`, color fixed.
    Depth,
    /// `E_I`, depth fixed.
    Color,
}

/// The course of one linear solve.
#[derive(Clone, Debug)]
pub struct SolveTrace {
    /// Pyramid level.
    pub level: usize,
    /// Outer iteration at that level.
    pub iteration: usize,
    /// Depth or color.
    pub kind: SolveKind,
    /// The energy before the first sweep and after each sweep.
    pub energies: Vec<f64>,
    /// Relative residual `||b - A u|| / ||b||` after the last sweep.
    pub final_residual: f64,
}

impl SolveTrace {
    /// An empty trace of one solve (energies and residual filled in as it runs).
    pub(super) fn start(level: usize, iteration: usize, kind: SolveKind) -> Self {
        Self { level, iteration, kind, energies: Vec::new(), final_residual: f64::NAN }
    }
}
