//! Densification (METHOD.md Part 1 step 4): PatchMatch stereo grows a time step's sparse points
//! into a denser, still compact cloud with colors.
//!
//! 1. `view`: every frame is reduced (INTER_AREA) to at most
//!    [`DensifyOptions::max_side_px`], in grayscale `f32`, with its intrinsics scaled.
//! 2. `patchmatch`: per reference view, a depth and a normal per pixel, initialised at random
//!    within the depth range of the sparse points seen by the view (pixels under a sparse point
//!    start from its depth), scored by `1 - NCC` through the plane-induced homography against the
//!    [`DensifyOptions::source_views`] views whose optical axes are closest, and improved by
//!    alternating raster sweeps (propagation from the neighbours, random refinement with a
//!    shrinking perturbation). The views run in parallel (rayon); every random number is a hash
//!    of the pixel, the view and the sweep, so the output does not depend on the threads.
//! 3. `fuse`: pixels under the cost threshold that agree with the depth maps of at least
//!    [`DensifyOptions::min_consistent_views`] other views become world points (mean of the
//!    agreeing views' points and colors), merged with the sparse points on a voxel grid
//!    (sparse points first) and evenly thinned to [`DensifyOptions::target_points`].

mod fuse;
mod patchmatch;
mod view;

use rayon::prelude::*;

use crate::error::SfmResult;
use crate::mapping::points::{TimestepCloud, TimestepView};

/// How a time step's sparse cloud is densified. The defaults are tuned on the synthetic event with
/// 6 views of 960x540: about 0.7 s per time step on two cores (1.4 s of CPU), median depth error
/// about 0.07%, about 60 000 consistent points before thinning (see `examples/densify_speed.rs`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DensifyOptions {
    /// Most points in the result, sparse points included.
    pub target_points: usize,
    /// Longest side (px) of the frames while matching; larger frames are reduced (INTER_AREA).
    pub max_side_px: usize,
    /// PatchMatch iterations; each is a forward and a backward raster sweep.
    pub iterations: usize,
    /// Half-size of the matching window, in samples (window of `2 r + 1` squared samples; 1 to 7).
    pub window_radius: usize,
    /// Pixels between two samples of the matching window (1 to 8).
    pub window_stride: usize,
    /// Source views matched against each reference view (closest optical axes first; at most 8).
    pub source_views: usize,
    /// The cost of a hypothesis is the mean of the best this many source views' costs.
    pub best_sources: usize,
    /// Smallest normalized cross-correlation for a pixel to be kept.
    pub min_ncc: f32,
    /// Largest relative difference of depths for two views to agree on a point.
    pub max_relative_depth_difference: f32,
    /// Other views whose depth maps must agree with a pixel for it to become a point (all the other
    /// depth maps when there are fewer).
    pub min_consistent_views: usize,
    /// Relative margin added to the sparse points' depth range (2nd to 98th percentile) of a view.
    pub depth_range_margin: f64,
    /// Edge of the voxels that merge duplicates, in working pixels at the median depth.
    pub voxel_px: f64,
    /// Seed of the random hypotheses.
    pub seed: u64,
}

impl Default for DensifyOptions {
    fn default() -> Self {
        Self {
            target_points: 16_000,
            max_side_px: 256,
            iterations: 2,
            window_radius: 2,
            window_stride: 2,
            source_views: 2,
            best_sources: 1,
            min_ncc: 0.6,
            max_relative_depth_difference: 0.01,
            min_consistent_views: 2,
            depth_range_margin: 0.25,
            voxel_px: 1.0,
            seed: 0x5eed,
        }
    }
}

/// Grows `sparse` (the time step's triangulated points) into a denser cloud of at most
/// `options.target_points` points, deterministic for given inputs.
///
/// The sparse points are kept first (those with non-finite coordinates are dropped); dense points
/// falling in a sparse point's voxel are dropped in its favour. A dense point's `views` counts the views
/// that agree on it, its reference view included. With fewer than two views, or without sparse
/// points (they give each view its depth range), the result is the sparse cloud itself, thinned to
/// the target. Views whose frame is not 8-bit BGR, whose calibration is not finite, or that see
/// fewer than 3 sparse points, get no depth map.
pub fn densify(views: &[TimestepView], sparse: &TimestepCloud, options: &DensifyOptions) -> SfmResult<TimestepCloud> {
    let sparse = fuse::finite_sparse(sparse);
    if views.len() < 2 || sparse.positions_world.is_empty() || options.target_points <= sparse.positions_world.len() {
        return Ok(fuse::reduce(&sparse, Vec::new(), 1.0, options.target_points));
    }
    let work: Vec<Option<view::WorkView>> =
        views.par_iter().map(|v| view::WorkView::from_view(v, options.max_side_px)).collect::<SfmResult<_>>()?;
    let maps: Vec<Option<patchmatch::DepthMap>> =
        (0..work.len()).into_par_iter().map(|r| patchmatch::depth_map(r, &work, &sparse.positions_world, options)).collect();
    let (candidates, voxel_m) = fuse::candidates(&work, &maps, options);
    Ok(fuse::reduce(&sparse, candidates, voxel_m, options.target_points))
}
