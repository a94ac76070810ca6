//! Timings and the SfM comparison (`dynview-eval bench`, `bench-prep`, `bench-sfm`):
//!
//! - [`render`]: milliseconds per frame on the CPU and the GPU;
//! - [`prep`]: the whole `dynview prep` timed and scored;
//! - [`sfm`]: our keyframe SfM against COLMAP and ground truth.

pub mod prep;
pub mod render;
pub mod sfm;
