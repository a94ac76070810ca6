//! Bundle adjustment of the map (`dynview-ba`): the problem of every registered image and
//! point, the final adjustment that tries the principal points, applying a solution and
//! dropping the outliers; and the refinement of one image's pose on fixed points.

use dynview_camera::{PoseMatrices, Radial, Rigid3};

use super::{MapPoint, Mapper};
use crate::error::SfmResult;

/// What [`solve_final`] found.
pub(crate) struct FinalSolve {
    /// The solve's report.
    pub report: dynview_ba::Report,
    /// The kept solution's intrinsics' standard deviations, per camera.
    pub std: Vec<dynview_ba::IntrinsicsStd>,
    /// Per camera, the principal point's standard deviation (px) in the trial with it refined;
    /// empty when there was no trial.
    pub principal_point_std_px: Vec<Option<f64>>,
    /// Whether the refined principal points were kept.
    pub principal_point_refined: bool,
}

/// The final adjustment of `problem` under `options`: with `try_principal_points` it first
/// solves with the principal points refined too, and keeps that solution only when every
/// camera's principal point is fixed by the data to within its prior (`prior_px`, from
/// [`PRINCIPAL_POINT_PRIOR_FRACTION`]): the estimate is then expected nearer the truth than
/// where it started (the image centre). Otherwise it solves with them where they are. Where
/// the normal equations are singular beyond the gauge (some unknown the data do not fix at
/// all), the trial's principal points count as not fixed (standard deviation infinite) and
/// the kept solution's standard deviations as unknown (empty): the measure never fails a
/// reconstruction that solved.
pub(crate) fn solve_final(
    problem: &mut dynview_ba::Problem,
    options: dynview_ba::Options,
    try_principal_points: bool,
    prior_px: &[f64],
) -> SfmResult<FinalSolve> {
    let mut principal_point_std_px = Vec::new();
    if try_principal_points {
        let trial_options = dynview_ba::Options { refine_principal_point: true, ..options };
        let mut trial = problem.clone();
        let report = dynview_ba::solve(&mut trial, &trial_options)?;
        match intrinsics_std_if_fixed(&trial, &trial_options, report.final_rms_px)? {
            Some(std) => {
                principal_point_std_px = std.iter().map(|s| s.principal_point_px).collect();
                if principal_point_std_px.iter().zip(prior_px).all(|(s, prior)| s.is_none_or(|s| s <= *prior)) {
                    *problem = trial;
                    return Ok(FinalSolve { report, std, principal_point_std_px, principal_point_refined: true });
                }
            }
            None => principal_point_std_px = vec![Some(f64::INFINITY); problem.cameras.len()],
        }
    }
    let report = dynview_ba::solve(problem, &options)?;
    let std = intrinsics_std_if_fixed(problem, &options, report.final_rms_px)?.unwrap_or_default();
    Ok(FinalSolve { report, std, principal_point_std_px, principal_point_refined: false })
}

/// [`dynview_ba::intrinsics_std`], or `None` where the normal equations cannot be factorised
/// (singular beyond the gauge: some unknown is not fixed by the data at all).
fn intrinsics_std_if_fixed(
    problem: &dynview_ba::Problem,
    options: &dynview_ba::Options,
    noise_px: f64,
) -> SfmResult<Option<Vec<dynview_ba::IntrinsicsStd>>> {
    match dynview_ba::intrinsics_std(problem, options, noise_px) {
        Ok(std) => Ok(Some(std)),
        Err(dynview_ba::BaError::Numerical { .. }) => Ok(None),
        Err(other) => Err(other.into()),
    }
}

/// Which map images and points a bundle adjustment problem's images and points are.
pub(super) struct ProblemIds {
    pub(super) images: Vec<usize>,
    pub(super) points: Vec<usize>,
}

/// Refines one image's pose on fixed 3D points (robust loss).
pub fn refine_pose(k: &Radial, pose: Rigid3, correspondences: &[([f64; 3], [f64; 2])], loss_scale_px: f64) -> SfmResult<Rigid3> {
    let mut problem = dynview_ba::Problem {
        cameras: vec![*k],
        images: vec![pose],
        image_camera: vec![0],
        image_fixed: vec![false],
        points_world: correspondences.iter().map(|c| c.0).collect(),
        point_fixed: vec![true; correspondences.len()],
        observations: correspondences.iter().enumerate().map(|(p, c)| dynview_ba::Observation { image: 0, point: p, pixel: c.1 }).collect(),
        priors: Vec::new(),
        held_intrinsics: Vec::new(),
    };
    let options = dynview_ba::Options {
        loss: dynview_ba::Loss::Cauchy { scale_px: loss_scale_px },
        refine_focal: false,
        refine_principal_point: false,
        refine_distortion: false,
        max_iterations: 30,
        ..Default::default()
    };
    dynview_ba::solve(&mut problem, &options)?;
    Ok(problem.images[0])
}

impl Mapper<'_> {
    /// Global bundle adjustment of every registered image and point, then outlier filtering.
    /// `last`: the final adjustment, which also refines what the options allow beyond focals.
    pub(super) fn bundle_adjust(&mut self, refine_focal: bool, last: bool) -> SfmResult<()> {
        let (mut problem, ids) = self.ba_problem();
        let options = self.ba_options(refine_focal, last);
        if last {
            let solved = solve_final(&mut problem, options, self.options.refine_principal_point, &self.principal_prior_px)?;
            self.principal_point_std_px = solved.principal_point_std_px;
            self.principal_point_refined = solved.principal_point_refined;
            self.focal_std_px = solved.std.iter().map(|s| s.focal_px).collect();
        } else {
            dynview_ba::solve(&mut problem, &options)?;
        }
        self.apply_solution(&problem, &ids);
        Ok(())
    }

    /// The bundle adjustment options of [`Self::bundle_adjust`].
    pub(super) fn ba_options(&self, refine_focal: bool, last: bool) -> dynview_ba::Options {
        dynview_ba::Options {
            loss: dynview_ba::Loss::Cauchy { scale_px: self.options.loss_scale_px },
            refine_focal: refine_focal && self.options.refine_focal,
            refine_principal_point: false,
            refine_distortion: last && self.options.refine_distortion,
            max_iterations: 50,
            ..Default::default()
        }
    }

    /// Every registered image and point as a bundle adjustment problem, with the images' and
    /// points' indices in the map of its images and points.
    pub(super) fn ba_problem(&self) -> (dynview_ba::Problem, ProblemIds) {
        let image_ids: Vec<usize> = (0..self.poses.len()).filter(|&i| self.poses[i].is_some()).collect();
        let mut slot = vec![usize::MAX; self.poses.len()];
        for (s, &i) in image_ids.iter().enumerate() {
            slot[i] = s;
        }
        let point_ids: Vec<usize> = (0..self.points.len()).filter(|&p| self.points[p].is_some()).collect();
        let mut problem = dynview_ba::Problem {
            cameras: self.intrinsics.clone(),
            images: image_ids.iter().map(|&i| self.poses[i].unwrap_or_else(|| unreachable!())).collect(),
            image_camera: image_ids.iter().map(|&i| self.images[i].camera).collect(),
            image_fixed: image_ids.iter().map(|&i| i == self.fixed_image).collect(),
            points_world: point_ids.iter().map(|&p| self.points[p].as_ref().map_or([0.0; 3], |q| q.xyz.into())).collect(),
            point_fixed: vec![false; point_ids.len()],
            observations: Vec::new(),
            priors: Vec::new(),
            held_intrinsics: self.held.clone(),
        };
        for (s, &p) in point_ids.iter().enumerate() {
            for &(i, f) in &self.points[p].as_ref().map_or(&Vec::new(), |q| &q.observations).clone() {
                problem.observations.push(dynview_ba::Observation { image: slot[i], point: s, pixel: self.observation(i, f).into() });
            }
        }
        (problem, ProblemIds { images: image_ids, points: point_ids })
    }

    /// Takes the poses, points and intrinsics of a solved [`Self::ba_problem`], then drops the
    /// outliers.
    pub(super) fn apply_solution(&mut self, problem: &dynview_ba::Problem, ids: &ProblemIds) {
        for (s, &i) in ids.images.iter().enumerate() {
            self.poses[i] = Some(problem.images[s]);
        }
        for (s, &p) in ids.points.iter().enumerate() {
            if let Some(point) = &mut self.points[p] {
                point.xyz = problem.points_world[s].into();
            }
        }
        self.intrinsics.clone_from(&problem.cameras);
        self.filter_outliers();
    }

    /// Drops observations above the reprojection limit and points left with fewer than two.
    pub(super) fn filter_outliers(&mut self) {
        let poses: Vec<Option<PoseMatrices>> = self.poses.iter().map(|pose| pose.map(|pose| pose.matrices())).collect();
        for t in 0..self.point_of_track.len() {
            let Some(p) = self.point_of_track[t] else { continue };
            let Some(point) = self.points[p].take() else { continue };
            let observations: Vec<(usize, u32)> = point
                .observations
                .iter()
                .copied()
                .filter(|&(i, f)| self.error(poses[i].as_ref(), i, f, &point.xyz) <= self.options.max_reprojection_px)
                .collect();
            if observations.len() >= 2 {
                self.points[p] = Some(MapPoint { xyz: point.xyz, observations });
            } else {
                self.point_of_track[t] = None;
            }
        }
    }
}
