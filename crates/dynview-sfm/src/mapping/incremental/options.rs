//! How the keyframe reconstruction runs: [`MapperOptions`] and the principal-point prior.

/// How the keyframe reconstruction runs.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MapperOptions {
    /// Largest reprojection error (px) of an observation kept in the model.
    pub max_reprojection_px: f64,
    /// Smallest angle (degrees) between two rays of a new point.
    pub min_triangulation_angle_deg: f64,
    /// Fewest 2D-3D inliers to register an image.
    pub min_registration_inliers: usize,
    /// Fewest points of an initial pair.
    pub min_initial_points: usize,
    /// An initial pair is taken at once when the median angle between its rays is at least
    /// this (degrees); otherwise the pair with the widest median angle among the candidates.
    pub init_min_median_angle_deg: f64,
    /// Cauchy loss scale (px) of bundle adjustment and pose refinement: observations much
    /// farther than this from their projection weigh little. Default
    /// [`dynview_ba::DEFAULT_LOSS_SCALE_PX`] (1 px, COLMAP's): 0.25 px gives better keyframe
    /// models on sharp, lossless frames, but not from videos across events
    /// (`docs/results/sfm.md`, "The robust loss at a quarter pixel").
    pub loss_scale_px: f64,
    /// Cameras with the same image size share one set of intrinsics (one camera model filmed
    /// everything). Off by default: cameras at an event are different phones and zooms, and
    /// equal image sizes say nothing about equal intrinsics.
    pub share_intrinsics: bool,
    /// Refine the focal lengths in bundle adjustment (those the user did not give).
    pub refine_focal: bool,
    /// Refine the principal points in the final bundle adjustment where the data fix them
    /// better than their usual distance from the centre ([`PRINCIPAL_POINT_PRIOR_FRACTION`];
    /// on by default; COLMAP keeps them at the image centre). On the Middlebury temple this cut the
    /// median rotation error from 0.62 to 0.25 degrees (`docs/results/sfm.md`).
    pub refine_principal_point: bool,
    /// Refine the radial distortion (k1, k2) in the final bundle adjustment (off by default:
    /// with few viewpoints it trades off against the focal length).
    pub refine_distortion: bool,
}

impl Default for MapperOptions {
    fn default() -> Self {
        Self {
            max_reprojection_px: 4.0,
            min_triangulation_angle_deg: 1.5,
            min_registration_inliers: 20,
            min_initial_points: 50,
            init_min_median_angle_deg: 10.0,
            loss_scale_px: dynview_ba::DEFAULT_LOSS_SCALE_PX,
            share_intrinsics: false,
            refine_focal: true,
            refine_principal_point: true,
            refine_distortion: false,
        }
    }
}

/// How far real principal points lie from the image centre, as a share of the longer image
/// side (radially): 0.6-1.9% on the Panoptic cameras, 0.5-1.6% on Pose2Sim's, 2.9% on the
/// Middlebury temple.
/// The final adjustment keeps refined principal points only when the data fix every camera's
/// better than this (its standard deviation, px along the worse axis at the adjustment's RMS
/// error as noise, below this share of its longer side): then the estimate is expected nearer
/// the truth than the centre is. An arc of cameras hardly tells a principal point from a
/// common turn of its images; a ring, or images at different rolls, does.
pub const PRINCIPAL_POINT_PRIOR_FRACTION: f64 = 0.015;
