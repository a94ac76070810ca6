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
mod options;
mod patchmatch;
mod view;

pub use options::DensifyOptions;

use rayon::prelude::*;

use crate::error::SfmResult;
use crate::mapping::points::{TimestepCloud, TimestepView};

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
