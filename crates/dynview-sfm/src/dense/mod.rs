//! Dense points: a time step's sparse points grown by PatchMatch stereo ([`densify`]), and the
//! static points accumulated across time and lent to the steps that agree with them
//! ([`static_cloud`]); the background plates of the cameras that stand still ([`plates`]) and the static cloud grown
//! from them ([`plate_cloud`]), which repairs the plates where someone stood longer than the
//! background was seen ([`plate_repair`]); the visual hull of what moves, carved from the plates'
//! foregrounds ([`hull`]), a hand-held camera's from plates made per step of its
//! neighbouring frames ([`moving_plates`]); the step's own points that float where the plates show free space
//! dropped ([`free_space`]).

pub mod densify;
pub mod free_space;
pub mod hull;
pub mod moving_plates;
pub mod plate_cloud;
pub mod plate_repair;
pub mod plates;
pub mod static_cloud;

pub use plates::{Plate, PlateEstimator, PlateMode, PlateOptions};
