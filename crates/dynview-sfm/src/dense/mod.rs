//! Dense points: a time step's sparse points grown by PatchMatch stereo ([`densify`]), and the
//! static points accumulated across time and lent to the steps that agree with them
//! ([`static_cloud`]).

pub mod densify;
pub mod static_cloud;
