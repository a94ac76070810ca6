//! COLMAP's camera model names, ids and parameter lists.

/// The COLMAP camera models dynview reads and writes. Names, ids and parameter orders as in
/// COLMAP's `src/colmap/sensor/models.h`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CameraModel {
    /// `f, cx, cy`: [`crate::SimplePinhole`].
    SimplePinhole,
    /// `fx, fy, cx, cy`: [`crate::Pinhole`].
    Pinhole,
    /// `f, cx, cy, k`: [`crate::SimpleRadial`].
    SimpleRadial,
    /// `f, cx, cy, k1, k2`: [`crate::Radial`].
    Radial,
    /// `fx, fy, cx, cy, k1, k2, p1, p2`: [`crate::OpenCv`].
    OpenCv,
}

impl CameraModel {
    /// Every supported model, in the order of COLMAP's ids.
    pub const ALL: [Self; 5] = [Self::SimplePinhole, Self::Pinhole, Self::SimpleRadial, Self::Radial, Self::OpenCv];

    /// COLMAP's name of the model (text files).
    pub fn name(self) -> &'static str {
        match self {
            Self::SimplePinhole => "SIMPLE_PINHOLE",
            Self::Pinhole => "PINHOLE",
            Self::SimpleRadial => "SIMPLE_RADIAL",
            Self::Radial => "RADIAL",
            Self::OpenCv => "OPENCV",
        }
    }

    /// COLMAP's numeric id of the model (binary files).
    pub fn id(self) -> i32 {
        match self {
            Self::SimplePinhole => 0,
            Self::Pinhole => 1,
            Self::SimpleRadial => 2,
            Self::Radial => 3,
            Self::OpenCv => 4,
        }
    }

    /// The model with COLMAP name `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The model with COLMAP id `id`.
    pub fn from_id(id: i32) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.id() == id)
    }

    /// The parameters' names in COLMAP's order (COLMAP's `params_info`).
    pub fn param_names(self) -> &'static [&'static str] {
        match self {
            Self::SimplePinhole => &["f", "cx", "cy"],
            Self::Pinhole => &["fx", "fy", "cx", "cy"],
            Self::SimpleRadial => &["f", "cx", "cy", "k"],
            Self::Radial => &["f", "cx", "cy", "k1", "k2"],
            Self::OpenCv => &["fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"],
        }
    }

    /// Number of parameters.
    pub fn param_count(self) -> usize {
        self.param_names().len()
    }
}

impl std::fmt::Display for CameraModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
