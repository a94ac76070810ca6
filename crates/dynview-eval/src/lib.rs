//! dynview's evaluations and benchmarks, as a library for the `dynview-eval` binary (which
//! `cargo xtask eval` and `cargo xtask bench` run in release mode) and for tests. Its stages,
//! each folder using only those before it:
//!
//! - [`paths`] and [`align`] (similarity alignment and the pose accuracy of a reconstruction):
//!   shared helpers;
//! - [`datasets`]: the synthetic layouts, the SfM benchmark's datasets and the real captures
//!   (Panoptic's two arcs and Pose2Sim's lab), with their ground truth;
//! - [`runs`]: running `dynview prep`, our SfM and COLMAP, and reading what they wrote;
//! - [`eval`]: render quality of every method on the synthetic event's held-out cameras (from
//!   the ground-truth package and through the whole `dynview prep`) and leave-one-camera-out on
//!   the real captures;
//! - [`bench`]: milliseconds per frame on the CPU and the GPU, the whole `dynview prep` timed
//!   and scored, our keyframe SfM against COLMAP and ground truth.
//!
//! Every entry point is a command that runs programs, writes reports and stops at the first
//! failure with its context, so errors are `anyhow`'s, as in a binary.

pub mod align;
pub mod bench;
pub mod datasets;
pub mod eval;
pub mod paths;
pub mod runs;
