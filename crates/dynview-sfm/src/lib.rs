//! dynview's preprocessing.
use opencv::prelude::*;
/// Probe.
pub fn probe() -> opencv::Result<i32> { let m = opencv::core::Mat::zeros(2, 2, opencv::core::CV_8U)?.to_mat()?; Ok(m.rows()) }
