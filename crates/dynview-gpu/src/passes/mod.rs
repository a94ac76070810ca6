//! The compute passes of METHOD.md Part 2, each a set of kernels on the device layer
//! ([`crate::device`]) and each matching its dynview-core counterpart.
//!
//! From the bottom up: the image pyramid and push-pull ([`pyramid`]), the z-buffered splats
//! ([`splat`]) and the sparse consistency filter on them ([`consistency`]), the plates' static
//! mask from them ([`static_mask`]), the chosen views'
//! stacked images ([`views`]) and the backward warps into them ([`warp`]), the color initial
//! guess ([`blend`]), the weights and both systems ([`assemble`]), the rank preference
//! ([`rank`]), the temporal terms ([`temporal`]) and the red-black solver ([`solver`]). They use
//! the device layer and each other without circles, and nothing of the renderer above.

pub(crate) mod assemble;
pub(crate) mod blend;
pub(crate) mod consistency;
pub(crate) mod pyramid;
pub(crate) mod rank;
pub(crate) mod solver;
pub(crate) mod splat;
pub(crate) mod static_mask;
pub(crate) mod temporal;
pub(crate) mod views;
pub(crate) mod warp;
