//! Render quality against ground truth and real captures (`dynview-eval eval` and `eval-real`):
//!
//! - [`synthetic`]: the synthetic event's table, from the ground-truth package, with the
//!   [`pipeline`]'s rows from `dynview prep` on the event's videos; both render and score
//!   through [`scoring`] (options, held-out sequences, one method's row);
//! - [`objects`]: depth error on the synthetic event's moving objects;
//! - [`real`]: leave-one-camera-out on the real captures, with the [`plane_view`] experiment.

pub mod objects;
pub mod pipeline;
pub mod plane_view;
pub mod real;
pub mod scoring;
pub mod synthetic;
pub mod unsync_synthetic;
