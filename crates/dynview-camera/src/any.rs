//! Any model, chosen at run time from COLMAP's `(model, params)` pair.

use crate::{CameraModel, Model, OpenCv, Pinhole, Radial, SimplePinhole, SimpleRadial};

/// A camera of any supported model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Camera {
    /// `SIMPLE_PINHOLE`.
    SimplePinhole(SimplePinhole),
    /// `PINHOLE`.
    Pinhole(Pinhole),
    /// `SIMPLE_RADIAL`.
    SimpleRadial(SimpleRadial),
    /// `RADIAL`.
    Radial(Radial),
    /// `OPENCV`.
    OpenCv(OpenCv),
}

/// Calls `$body` with `$m` bound to the model inside `$camera`.
macro_rules! with_model {
    ($camera:expr, $m:ident => $body:expr) => {
        match $camera {
            Camera::SimplePinhole($m) => $body,
            Camera::Pinhole($m) => $body,
            Camera::SimpleRadial($m) => $body,
            Camera::Radial($m) => $body,
            Camera::OpenCv($m) => $body,
        }
    };
}

impl Camera {
    /// The camera of model `model` with parameters `params` in COLMAP's order; `None` unless
    /// `params` holds exactly [`CameraModel::param_count`] values.
    pub fn from_params(model: CameraModel, params: &[f64]) -> Option<Self> {
        Some(match model {
            CameraModel::SimplePinhole => Self::SimplePinhole(SimplePinhole::from_params(params)?),
            CameraModel::Pinhole => Self::Pinhole(Pinhole::from_params(params)?),
            CameraModel::SimpleRadial => Self::SimpleRadial(SimpleRadial::from_params(params)?),
            CameraModel::Radial => Self::Radial(Radial::from_params(params)?),
            CameraModel::OpenCv => Self::OpenCv(OpenCv::from_params(params)?),
        })
    }

    /// The camera's model.
    pub fn model(&self) -> CameraModel {
        match self {
            Self::SimplePinhole(_) => SimplePinhole::MODEL,
            Self::Pinhole(_) => Pinhole::MODEL,
            Self::SimpleRadial(_) => SimpleRadial::MODEL,
            Self::Radial(_) => Radial::MODEL,
            Self::OpenCv(_) => OpenCv::MODEL,
        }
    }

    /// The parameters in COLMAP's order.
    pub fn params(&self) -> Vec<f64> {
        with_model!(self, m => m.params())
    }

    /// See [`Model::distort`].
    pub fn distort(&self, normalized: [f64; 2]) -> [f64; 2] {
        with_model!(self, m => m.distort(normalized))
    }

    /// See [`Model::undistort`].
    pub fn undistort(&self, distorted: [f64; 2]) -> [f64; 2] {
        with_model!(self, m => m.undistort(distorted))
    }

    /// See [`Model::pixel_from_normalized`].
    pub fn pixel_from_normalized(&self, normalized: [f64; 2]) -> [f64; 2] {
        with_model!(self, m => m.pixel_from_normalized(normalized))
    }

    /// See [`Model::normalized_from_pixel`].
    pub fn normalized_from_pixel(&self, pixel: [f64; 2]) -> [f64; 2] {
        with_model!(self, m => m.normalized_from_pixel(pixel))
    }

    /// The same camera as an [`OpenCv`] model (every model here is a special case of it).
    pub fn to_opencv(&self) -> OpenCv {
        with_model!(self, m => m.to_opencv())
    }
}

/// The pixel of the undistorted normalized point `normalized` (`[X/Z, Y/Z]`) in a camera of
/// model `model` with parameters `params` in COLMAP's order and pixel convention; `None` when
/// `params` does not hold exactly the model's number of parameters.
pub fn pixel_from_normalized(model: CameraModel, params: &[f64], normalized: [f64; 2]) -> Option<[f64; 2]> {
    Camera::from_params(model, params).map(|camera| camera.pixel_from_normalized(normalized))
}

/// The undistorted normalized point of `pixel` in a camera of model `model` with parameters
/// `params`; `None` when `params` does not hold exactly the model's number of parameters.
pub fn normalized_from_pixel(model: CameraModel, params: &[f64], pixel: [f64; 2]) -> Option<[f64; 2]> {
    Camera::from_params(model, params).map(|camera| camera.normalized_from_pixel(pixel))
}
