//! The driver: what `prep` can be told and what it reports ([`options`]), the stages in order
//! ([`prep`]), each saved in the work folder and skipped on a re-run: the frames and pose stages
//! ([`poses`], with [`still_placement`] for aligning uncalibrated cameras from the pictures), the per-timestep stage ([`timesteps`]), and the scene package from one run or
//! several range runs ([`export`]).

pub mod export;
pub mod options;
pub mod poses;
pub mod prep;
pub mod still_placement;
pub mod timesteps;
