//! dynview's evaluations and benchmarks, as a library for the `dynview-eval` binary (which
//! `cargo xtask eval` and `cargo xtask bench` run in release mode) and for tests:
//!
//! - [`align`]: similarity (Umeyama) alignment and the pose accuracy of a reconstruction;
//! - [`eval`], [`eval_pipeline`]: render quality of every method on the synthetic event's
//!   held-out cameras, from the ground-truth package and through the whole `dynview prep`;
//! - [`eval_real`]: leave-one-camera-out on the real captures ([`real_captures`]: Panoptic's
//!   arc and Pose2Sim's lab);
//! - [`bench_render`]: milliseconds per frame on the CPU and the GPU;
//! - [`bench_prep`]: the whole `dynview prep` timed and scored;
//! - [`bench_sfm`]: our keyframe SfM against COLMAP and ground truth;
//! - the datasets and runners these share ([`sfm_datasets`], [`sfm_runners`], [`sfm_data`],
//!   [`pose2sim`], [`panoptic`], [`prep_runs`], [`paths`]).
//!
//! Every entry point is a command that runs programs, writes reports and stops at the first
//! failure with its context, so errors are `anyhow`'s, as in a binary.

pub mod align;
pub mod bench_prep;
pub mod bench_render;
pub mod bench_sfm;
pub mod eval;
pub mod eval_pipeline;
pub mod eval_real;
pub mod panoptic;
pub mod paths;
pub mod plane_view;
pub mod pose2sim;
pub mod prep_runs;
pub mod real_captures;
pub mod sfm_data;
pub mod sfm_datasets;
pub mod sfm_runners;
