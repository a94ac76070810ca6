//! Poses and sparse points: the keyframes ([`keyframes`]) and their reconstruction
//! ([`keyframe_model`]: incremental, [`incremental`], with cameras that stand still pooled,
//! [`still`]); every other frame posed by the frame-to-frame refinement ([`refine`]); the
//! intrinsics and poses adjusted over sampled time steps ([`step_adjust`]), still cameras the
//! keyframes left out placed from them first ([`step_placement`]); and the points of
//! one time step, triangulated across cameras with the poses known ([`points`]).

pub mod incremental;
pub mod keyframe_model;
pub mod keyframes;
pub mod points;
pub mod refine;
pub mod step_adjust;
pub mod step_placement;
pub mod still;
