//! Running the programs under evaluation and reading what they wrote:
//!
//! - [`programs`]: the `dynview` binary, and commands run with their output in a log;
//! - [`prep`]: `dynview prep` runs, their stage times, poses and clouds;
//! - [`sfm`]: the SfM benchmark's two reconstructions, COLMAP's and ours.
//!
//! The evaluations ([`crate::eval`]) and the benchmarks ([`crate::bench`]) build on these.

pub mod prep;
pub mod programs;
pub mod sfm;
