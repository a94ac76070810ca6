//! Similarity alignment of point sets and the pose accuracy of a reconstruction.
//!
//! [`similarity_from_point_pairs`] is Umeyama's least-squares similarity ("Least-squares
//! estimation of transformation parameters between two point patterns", PAMI 1991, Eqs. 40-42):
//! `target ≈ s R source + t`. The rotation that maximises `tr(R^T Σ)` is found with Horn's
//! quaternion method (JOSA A 1987), which gives the same proper rotation as Umeyama's SVD with
//! its reflection fix, without an SVD (glam has none); the scale is Umeyama's
//! `s = tr(D S) / σ_x² = Σ (y_i - ȳ)·R(x_i - x̄) / Σ |x_i - x̄|²`.
//!
//! [`evaluate_poses`] compares estimated `camera_from_world` poses with ground truth, both
//! keyed by image name: it aligns the estimated camera centres to the true ones by a similarity,
//! then reports per image the rotation error in degrees and the centre error as a fraction of
//! the *scene size*, the diagonal of the bounding box of all ground-truth camera centres.

use std::collections::BTreeMap;

use glam::{DMat3, DVec3};

use dynview_core::Rigid3;
use dynview_core::camera::Intrinsics;
use dynview_core::rotation::angle_axis_from_matrix;

/// Errors of alignment and pose evaluation.
#[derive(Debug, thiserror::Error)]
pub enum AlignError {
    /// Source and target point lists differ in length.
    #[error("{source_len} source points but {target_len} target points")]
    LengthMismatch {
        /// Number of source points.
        source_len: usize,
        /// Number of target points.
        target_len: usize,
    },
    /// Fewer point pairs than a similarity needs.
    #[error("{found} point pairs; a similarity needs at least {MIN_POINTS}")]
    TooFewPoints {
        /// Number of pairs given.
        found: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("point {index} is not finite")]
    NonFinite {
        /// Index of the offending pair.
        index: usize,
    },
    /// The source points are (nearly) collinear or coincident, so the rotation is undefined.
    #[error("the source points are collinear or coincident; the similarity is undefined")]
    Degenerate,
    /// All ground-truth camera centres coincide, so the scene has no size.
    #[error("the ground-truth camera centres all coincide; the scene size is zero")]
    ZeroSceneSize,
}

/// Fewest point pairs for a similarity (three non-collinear points).
pub const MIN_POINTS: usize = 3;

/// Share of image pairs kept by the robust re-fit of [`evaluate_poses`] (the best 80%).
pub const ROBUST_INLIER_FRACTION: f64 = 0.8;

/// Relative size of the second principal variance below which the source is called collinear.
const COLLINEAR_TOLERANCE: f64 = 1e-12;

/// A similarity transform `p_to = scale * rotation * p_from + translation`. Name values after
/// the frames they connect, e.g. `true_from_estimated: Similarity3`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity3 {
    /// Scale factor (positive).
    pub scale: f64,
    /// Rotation (orthonormal, determinant +1).
    pub rotation: DMat3,
    /// Translation.
    pub translation: DVec3,
}

impl Similarity3 {
    /// The identity.
    pub const IDENTITY: Self = Self { scale: 1.0, rotation: DMat3::IDENTITY, translation: DVec3::ZERO };

    /// Applies the similarity to a point.
    pub fn transform_point(&self, point: DVec3) -> DVec3 {
        self.scale * (self.rotation * point) + self.translation
    }

    /// The inverse similarity: if `self` is `b_from_a`, returns `a_from_b`.
    pub fn inverse(&self) -> Self {
        let rotation = self.rotation.transpose();
        let scale = 1.0 / self.scale;
        Self { scale, rotation, translation: -(scale * (rotation * self.translation)) }
    }

    /// Maps a `camera_from_world` pose of world `a` into world `b` when `self` is `b_from_a`:
    /// the camera centre goes through the similarity and the rotation becomes `R_cam R^T`
    /// (a world direction `d_b = R d_a` looks the same to the camera).
    pub fn transform_camera_from_world(&self, camera_from_a: &Rigid3) -> Rigid3 {
        let rotation = camera_from_a.rotation * self.rotation.transpose();
        let center_b = self.transform_point(camera_from_a.camera_center_world());
        Rigid3::new(rotation, -(rotation * center_b))
    }
}

/// Umeyama's least-squares similarity `target_from_source` with
/// `target[i] ≈ s R source[i] + t` (see the module documentation).
pub fn similarity_from_point_pairs(source: &[DVec3], target: &[DVec3]) -> Result<Similarity3, AlignError> {
    if source.len() != target.len() {
        return Err(AlignError::LengthMismatch { source_len: source.len(), target_len: target.len() });
    }
    if source.len() < MIN_POINTS {
        return Err(AlignError::TooFewPoints { found: source.len() });
    }
    if let Some(index) = source.iter().zip(target).position(|(s, t)| !s.is_finite() || !t.is_finite()) {
        return Err(AlignError::NonFinite { index });
    }
    let n = source.len() as f64;
    let mean_source = source.iter().sum::<DVec3>() / n;
    let mean_target = target.iter().sum::<DVec3>() / n;
    // Cross-covariance Σ = Σ_i (y_i - ȳ)(x_i - x̄)^T and the source's own covariance.
    let mut cross = [[0.0; 3]; 3];
    let mut source_cov = [[0.0; 3]; 3];
    let mut source_var = 0.0;
    for (s, t) in source.iter().zip(target) {
        let x = (*s - mean_source).to_array();
        let y = (*t - mean_target).to_array();
        for r in 0..3 {
            for c in 0..3 {
                cross[r][c] += y[r] * x[c];
                source_cov[r][c] += x[r] * x[c];
            }
        }
        source_var += x.iter().map(|v| v * v).sum::<f64>();
    }
    let (source_eigen, _) = symmetric_eigen(source_cov);
    let mut spread = source_eigen;
    spread.sort_by(|a, b| b.total_cmp(a));
    if source_var <= 0.0 || spread[1] <= COLLINEAR_TOLERANCE * spread[0] {
        return Err(AlignError::Degenerate);
    }
    let rotation = rotation_maximising_trace(&cross);
    let mut correlation = 0.0;
    for (s, t) in source.iter().zip(target) {
        correlation += (*t - mean_target).dot(rotation * (*s - mean_source));
    }
    let scale = correlation / source_var;
    if !scale.is_finite() || scale <= 0.0 {
        return Err(AlignError::Degenerate);
    }
    Ok(Similarity3 { scale, rotation, translation: mean_target - scale * (rotation * mean_source) })
}

/// Pixels per side of the grid whose rays [`view_rotation`] matches.
const VIEW_GRID_SIDE: usize = 9;

/// The rotation `Q` (camera frame to camera frame) under which a camera with `estimated`
/// intrinsics sees through each pixel the ray that one with `reference` intrinsics sees through
/// it: `Q d_estimated ≈ d_reference` for the unit rays of a 9 x 9 grid of pixels spread over a
/// `width_px x height_px` image, in the least-squares sense (Wahba's problem).
///
/// A principal point `u` px off turns into a rotation of about `u / f`; a focal error alone into
/// none. Structure from motion trades the two along an arc of cameras (a weakly fixed mode):
/// a camera whose principal point is off, turned by the same angle, sees the world as the true
/// camera does. `Q R_est` is then the orientation of what the estimated camera sees, as a camera
/// with the reference intrinsics.
pub fn view_rotation(reference: &Intrinsics, estimated: &Intrinsics, width_px: u32, height_px: u32) -> DMat3 {
    let mut cross = [[0.0; 3]; 3];
    let last = (VIEW_GRID_SIDE - 1) as f64;
    for i in 0..VIEW_GRID_SIDE {
        for j in 0..VIEW_GRID_SIDE {
            let pixel =
                glam::DVec2::new(i as f64 / last * f64::from(width_px.max(1) - 1), j as f64 / last * f64::from(height_px.max(1) - 1));
            let seen = estimated.unproject(pixel, 1.0).normalize().to_array();
            let wanted = reference.unproject(pixel, 1.0).normalize().to_array();
            for r in 0..3 {
                for c in 0..3 {
                    cross[r][c] += wanted[r] * seen[c];
                }
            }
        }
    }
    rotation_maximising_trace(&cross)
}

/// The proper rotation `R` maximising `tr(R^T Σ)` for the cross-covariance `Σ[r][c] =
/// Σ_i y_r x_c` (Horn 1987: the eigenvector of the largest eigenvalue of the 4x4 matrix `N`).
fn rotation_maximising_trace(cross: &[[f64; 3]; 3]) -> DMat3 {
    // Horn's S_ab = Σ_i x_a y_b (source first), i.e. the transpose of `cross`.
    let s = |a: usize, b: usize| cross[b][a];
    let (sxx, sxy, sxz) = (s(0, 0), s(0, 1), s(0, 2));
    let (syx, syy, syz) = (s(1, 0), s(1, 1), s(1, 2));
    let (szx, szy, szz) = (s(2, 0), s(2, 1), s(2, 2));
    let n = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ];
    let (values, vectors) = symmetric_eigen(n);
    let best = (0..4).max_by(|&a, &b| values[a].total_cmp(&values[b])).unwrap_or(0);
    let q = glam::DQuat::from_xyzw(vectors[1][best], vectors[2][best], vectors[3][best], vectors[0][best]).normalize();
    DMat3::from_quat(q)
}

/// Eigenvalues and eigenvectors (columns: `vectors[row][k]` belongs to `values[k]`) of a
/// symmetric matrix by cyclic Jacobi rotations.
fn symmetric_eigen<const N: usize>(matrix: [[f64; N]; N]) -> ([f64; N], [[f64; N]; N]) {
    const SWEEPS: usize = 64;
    let mut a = matrix;
    let mut v = [[0.0; N]; N];
    for (i, row) in v.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for _ in 0..SWEEPS {
        let off: f64 = (0..N).flat_map(|p| (0..N).filter(move |&q| q != p).map(move |q| (p, q))).map(|(p, q)| a[p][q] * a[p][q]).sum();
        let total: f64 = a.iter().flatten().map(|x| x * x).sum();
        if off <= f64::EPSILON * f64::EPSILON * total {
            break;
        }
        for p in 0..N {
            for q in p + 1..N {
                if a[p][q] == 0.0 {
                    continue;
                }
                // Rotation in the (p, q) plane that zeroes a[p][q] (Golub & Van Loan 8.5.2).
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                // A <- J^T A J, V <- V J.
                for row in a.iter_mut().chain(v.iter_mut()) {
                    let (xp, xq) = (row[p], row[q]);
                    row[p] = c * xp - s * xq;
                    row[q] = s * xp + c * xq;
                }
                let (row_p, row_q) = (a[p], a[q]);
                for (k, (xp, xq)) in row_p.iter().zip(&row_q).enumerate() {
                    a[p][k] = c * xp - s * xq;
                    a[q][k] = s * xp + c * xq;
                }
            }
        }
    }
    (std::array::from_fn(|i| a[i][i]), v)
}

/// How [`evaluate_poses`] fits the similarity.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PoseEvalOptions {
    /// Re-fit the similarity on the [`ROBUST_INLIER_FRACTION`] of images whose aligned centres
    /// lie closest to the truth (after a first fit on all of them). The errors are still
    /// reported for every image.
    pub robust: bool,
    /// Fit the similarity's rotation to the camera centres alone (Umeyama). By default the
    /// rotation is the mean of `R_true^T R_est` over the images (their orientations fix it
    /// well even when the centres lie near a line or an arc, where a centres-only rotation is
    /// poorly determined about the line); scale and translation then come from the centres.
    pub centers_only: bool,
}

/// Errors of one image after alignment.
#[derive(Clone, Debug, PartialEq)]
pub struct ImagePoseError {
    /// Image name.
    pub name: String,
    /// Angle of `R_true (R_est R_sim^T)^T`, in degrees.
    pub rotation_error_deg: f64,
    /// Distance between the aligned estimated centre and the true centre, divided by the
    /// scene size.
    pub center_error_fraction: f64,
}

/// Pose accuracy of a reconstruction against ground truth.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseAccuracy {
    /// Images in the ground truth.
    pub ground_truth_images: usize,
    /// Ground-truth images the estimate registered (the images compared).
    pub registered: usize,
    /// Ground-truth images the estimate lacks, by name.
    pub missing: Vec<String>,
    /// Estimated images that the ground truth does not know (ignored).
    pub unknown: usize,
    /// Median rotation error over the registered images, in degrees.
    pub rotation_error_median_deg: f64,
    /// Largest rotation error, in degrees.
    pub rotation_error_max_deg: f64,
    /// Median centre error, as a fraction of the scene size.
    pub center_error_median_fraction: f64,
    /// Largest centre error, as a fraction of the scene size.
    pub center_error_max_fraction: f64,
    /// Diagonal of the bounding box of all ground-truth camera centres (ground-truth units).
    pub scene_size: f64,
    /// The fitted similarity from the estimate's world to the ground truth's world.
    pub true_from_estimated: Similarity3,
    /// Images whose pairs the final similarity was fitted on.
    pub fitted_on: usize,
    /// Per-image errors, sorted by name.
    pub per_image: Vec<ImagePoseError>,
}

/// Compares estimated `camera_from_world` poses with ground truth, both keyed by image name.
///
/// The estimated camera centres of the images present in both are aligned to the true centres
/// by [`similarity_from_point_pairs`] (least squares over all of them; with
/// [`PoseEvalOptions::robust`], re-fitted on the best [`ROBUST_INLIER_FRACTION`]). Per image,
/// the rotation error is the angle of `R_true (R_est R_sim^T)^T` (the estimated camera's
/// rotation expressed in the true world is `R_est R_sim^T`), and the centre error is
/// `|s R_sim C_est + t - C_true|` divided by the scene size: the diagonal of the bounding box
/// of *all* ground-truth camera centres, registered or not.
pub fn evaluate_poses(
    estimated: &BTreeMap<String, Rigid3>,
    ground_truth: &BTreeMap<String, Rigid3>,
    options: PoseEvalOptions,
) -> Result<PoseAccuracy, AlignError> {
    let true_centers: Vec<DVec3> = ground_truth.values().map(Rigid3::camera_center_world).collect();
    let scene_size = bounding_box_diagonal(&true_centers);
    if !scene_size.is_finite() || scene_size <= 0.0 {
        return Err(AlignError::ZeroSceneSize);
    }
    let common: Vec<(&String, &Rigid3, &Rigid3)> =
        ground_truth.iter().filter_map(|(name, truth)| estimated.get(name).map(|est| (name, est, truth))).collect();
    let missing: Vec<String> = ground_truth.keys().filter(|name| !estimated.contains_key(*name)).cloned().collect();
    let unknown = estimated.keys().filter(|name| !ground_truth.contains_key(*name)).count();
    let source: Vec<DVec3> = common.iter().map(|(_, est, _)| est.camera_center_world()).collect();
    let target: Vec<DVec3> = common.iter().map(|(_, _, truth)| truth.camera_center_world()).collect();
    let orientations: Vec<DMat3> = common.iter().map(|(_, est, truth)| truth.rotation.transpose() * est.rotation).collect();
    let fit = |indices: &[usize]| -> Result<Similarity3, AlignError> {
        let (src, dst): (Vec<DVec3>, Vec<DVec3>) = indices.iter().map(|&i| (source[i], target[i])).unzip();
        if options.centers_only {
            return similarity_from_point_pairs(&src, &dst);
        }
        let rotation = mean_rotation(&indices.iter().map(|&i| orientations[i]).collect::<Vec<_>>());
        similarity_given_rotation(&src, &dst, rotation)
    };
    let all: Vec<usize> = (0..source.len()).collect();
    let mut true_from_estimated = fit(&all)?;
    let mut fitted_on = source.len();
    if options.robust {
        let mut order: Vec<(f64, usize)> = source
            .iter()
            .zip(&target)
            .enumerate()
            .map(|(i, (s, t))| ((true_from_estimated.transform_point(*s) - *t).length(), i))
            .collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
        let keep = ((ROBUST_INLIER_FRACTION * source.len() as f64).ceil() as usize).clamp(MIN_POINTS, source.len());
        let kept: Vec<usize> = order[..keep].iter().map(|&(_, i)| i).collect();
        // A degenerate subset (e.g. the best 80% collinear) keeps the first fit.
        if let Ok(refit) = fit(&kept) {
            true_from_estimated = refit;
            fitted_on = keep;
        }
    }
    let per_image: Vec<ImagePoseError> = common
        .iter()
        .map(|(name, est, truth)| {
            let aligned = true_from_estimated.transform_camera_from_world(est);
            let relative = truth.rotation * aligned.rotation.transpose();
            ImagePoseError {
                name: (*name).clone(),
                rotation_error_deg: angle_axis_from_matrix(relative).length().to_degrees(),
                center_error_fraction: (aligned.camera_center_world() - truth.camera_center_world()).length() / scene_size,
            }
        })
        .collect();
    let rotation: Vec<f64> = per_image.iter().map(|e| e.rotation_error_deg).collect();
    let center: Vec<f64> = per_image.iter().map(|e| e.center_error_fraction).collect();
    Ok(PoseAccuracy {
        ground_truth_images: ground_truth.len(),
        registered: common.len(),
        missing,
        unknown,
        rotation_error_median_deg: median(&rotation),
        rotation_error_max_deg: rotation.iter().copied().fold(0.0, f64::max),
        center_error_median_fraction: median(&center),
        center_error_max_fraction: center.iter().copied().fold(0.0, f64::max),
        scene_size,
        true_from_estimated,
        fitted_on,
        per_image,
    })
}

/// The rotation nearest the mean of `rotations` (sign-aligned unit quaternions, averaged and
/// normalized: accurate for rotations that agree to within a few degrees).
pub fn mean_rotation(rotations: &[DMat3]) -> DMat3 {
    let Some(first) = rotations.first() else { return DMat3::IDENTITY };
    let q0 = glam::DQuat::from_mat3(first);
    let mut sum = glam::DVec4::ZERO;
    for r in rotations {
        let q = glam::DQuat::from_mat3(r);
        let v = glam::DVec4::from(q);
        sum += if v.dot(glam::DVec4::from(q0)) < 0.0 { -v } else { v };
    }
    DMat3::from_quat(glam::DQuat::from_vec4(sum).normalize())
}

/// The least-squares scale and translation of `target ≈ s R source + t` for a given `R`.
pub fn similarity_given_rotation(source: &[DVec3], target: &[DVec3], rotation: DMat3) -> Result<Similarity3, AlignError> {
    if source.len() != target.len() {
        return Err(AlignError::LengthMismatch { source_len: source.len(), target_len: target.len() });
    }
    if source.len() < 2 {
        return Err(AlignError::TooFewPoints { found: source.len() });
    }
    if let Some(index) = source.iter().zip(target).position(|(s, t)| !s.is_finite() || !t.is_finite()) {
        return Err(AlignError::NonFinite { index });
    }
    let n = source.len() as f64;
    let (mean_source, mean_target) = (source.iter().sum::<DVec3>() / n, target.iter().sum::<DVec3>() / n);
    let (mut num, mut den) = (0.0, 0.0);
    for (s, t) in source.iter().zip(target) {
        let x = rotation * (*s - mean_source);
        num += (*t - mean_target).dot(x);
        den += x.length_squared();
    }
    if den <= 0.0 || num <= 0.0 {
        return Err(AlignError::Degenerate);
    }
    let scale = num / den;
    Ok(Similarity3 { scale, rotation, translation: mean_target - scale * (rotation * mean_source) })
}

/// Diagonal length of the axis-aligned bounding box of `points` (0 for none).
pub fn bounding_box_diagonal(points: &[DVec3]) -> f64 {
    let Some(first) = points.first() else { return 0.0 };
    let (lo, hi) = points.iter().fold((*first, *first), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    (hi - lo).length()
}

/// Median of `values` (mean of the middle two for an even count; 0 for none).
pub(crate) fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mid = sorted.len() / 2;
    if sorted.len().is_multiple_of(2) { 0.5 * (sorted[mid - 1] + sorted[mid]) } else { sorted[mid] }
}

#[cfg(test)]
mod tests;
