//! Sparse bundle adjustment.
