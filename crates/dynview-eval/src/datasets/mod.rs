//! The data the evaluations and benchmarks run on, each made into `dynview prep` input or an
//! SfM benchmark's image folders, with its ground truth:
//!
//! - [`sfm`]: the SfM benchmark's datasets (synthetic layouts, the temple ring, Pose2Sim, the
//!   Panoptic arc) as image folders with true poses and intrinsics;
//! - [`real_captures`]: the real captures `eval-real` judges the renderer on, built on
//!   [`panoptic`] and [`pose2sim`] (the captures in `../shared/data`);
//! - [`colmap_models`]: COLMAP text models read as poses, and their reprojection errors.
//!
//! Nothing here runs `dynview` or COLMAP, or scores a method.

pub mod colmap_models;
pub mod panoptic;
pub mod pose2sim;
pub mod real_captures;
pub mod sfm;
