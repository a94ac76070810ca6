//! Geometric estimators: multi-view geometry, triangulation and reprojection errors
//! ([`geometry`]), two-view relative poses (`relative`, for the mapper), PnP ([`pnp`]) and
//! focal lengths by self-calibration ([`focal`]).

pub mod focal;
pub mod geometry;
pub mod pnp;
pub(crate) mod relative;
