//! How well the data fix each camera's intrinsics: the marginal standard deviations of its
//! focal length and principal point from the Gauss-Newton normal equations at the current
//! parameters.

use super::block_cholesky::NotPositiveDefinite;
use super::layout::{Layout, NodeKind};
use super::linearize::linearize;
use super::parameters::Parameters;
use super::step::reduced_system;
use crate::error::BaError;
use crate::options::Options;
use crate::problem::Problem;

/// Dampings of the reduced system, relative to its diagonal, tried in turn until it factors:
/// they remove the similarity gauge (the free scale) without touching the intrinsics (the
/// gauge leaves them unchanged, so their block of the inverse is that of the pseudo-inverse).
/// The smallest is tried first; forming the Schur complement cancels large terms, and where
/// the data fix some direction only weakly its round-off can outweigh 1e-9 of the diagonal
/// (on an arc of 12 cameras with their principal points refined, 2026-11-26). A larger damping
/// shortens only directions whose curvature is below it, so the standard deviations it gives
/// are lower bounds there.
const GAUGE_DAMPINGS: [f64; 4] = [1e-9, 1e-8, 1e-7, 1e-6];

/// How well the data fix one camera's refined intrinsics; `None` for what is not refined
/// (held, not asked for by the options, or no observation reaches the camera).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct IntrinsicsStd {
    /// Standard deviation of the focal length, px.
    pub focal_px: Option<f64>,
    /// Standard deviation of the principal point along its worse axis, px.
    pub principal_point_px: Option<f64>,
}

/// Per camera, the standard deviations of its refined intrinsics, `noise_px * sqrt(var)` with
/// the variances from `(J^T J)^-1` (robust weights as in the solve) after eliminating the
/// points; the principal point's is `sqrt(max(var cx, var cy))`. Each is marginal: it includes
/// what the other unknowns (poses, points, other intrinsics) leave undetermined. `noise_px` is
/// the standard deviation of one residual coordinate, for example the solve's final RMS.
pub fn intrinsics_std(problem: &Problem, options: &Options, noise_px: f64) -> Result<Vec<IntrinsicsStd>, BaError> {
    problem.validate()?;
    options.validate()?;
    let mut out = vec![IntrinsicsStd::default(); problem.cameras.len()];
    let layout = Layout::new(problem, options);
    if !layout.node_kind.iter().any(|k| matches!(k, NodeKind::Camera(_))) {
        return Ok(out);
    }
    let parameters = Parameters::from_problem(problem);
    let linearization = linearize(&layout, &parameters, &problem.priors, &options.loss);
    let pattern = &layout.pattern;
    let factored = |damping: f64| -> Result<Vec<f64>, NotPositiveDefinite> {
        let mut system = reduced_system(&layout, &linearization, damping)?;
        pattern.factor(&mut system.reduced)?;
        Ok(system.reduced)
    };
    let reduced = GAUGE_DAMPINGS.iter().find_map(|&damping| factored(damping).ok()).ok_or_else(|| BaError::Numerical {
        reason: format!("the normal equations could not be factorised, even damped by {:e} of their diagonal", GAUGE_DAMPINGS[3]),
    })?;
    let variance = |node: usize, local: usize| {
        let unknown = pattern.node_offset(node) + local;
        let mut unit = vec![0.0; pattern.dim()];
        unit[unknown] = 1.0;
        pattern.solve(&reduced, &unit)[unknown]
    };
    for (node, kind) in layout.node_kind.iter().enumerate() {
        let NodeKind::Camera(camera) = *kind else { continue };
        let free = &layout.free_intrinsics[camera];
        let std_of = |variance: f64| -> Result<f64, BaError> {
            if !variance.is_finite() {
                return Err(BaError::Numerical { reason: format!("camera {camera}: an intrinsic's variance is not finite") });
            }
            Ok(noise_px * variance.max(0.0).sqrt())
        };
        if let Some(local) = free.iter().position(|&index| index == 0) {
            out[camera].focal_px = Some(std_of(variance(node, local))?);
        }
        let principal: Vec<usize> = free.iter().enumerate().filter(|(_, index)| matches!(index, 1 | 2)).map(|(local, _)| local).collect();
        if !principal.is_empty() {
            let stds = principal.iter().map(|&local| std_of(variance(node, local))).collect::<Result<Vec<f64>, _>>()?;
            out[camera].principal_point_px = Some(stds.into_iter().fold(0.0, f64::max));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynview_camera::{Radial, Rigid3};

    use crate::problem::Observation;
    use crate::projection::pixel_from_world;

    /// `n` images of one camera on an arc of `arc_deg` around a cloud of 60 points at the
    /// origin, looking at it and rolled by up to `roll_deg`, observed exactly; the first image
    /// fixed. A principal point shift looks like a common turn of every image; only
    /// perspective and different rolls of one camera tell them apart.
    fn arc_problem(n: usize, arc_deg: f64, roll_deg: f64) -> Problem {
        let camera = Radial { f: 500.0, cx: 320.0, cy: 240.0, k1: 0.0, k2: 0.0 };
        let images: Vec<Rigid3> = (0..n)
            .map(|i| {
                let a = (arc_deg * (i as f64 / (n - 1) as f64 - 0.5)).to_radians();
                // Looking along +z rotated by a about y, from 6 m away.
                let roll = (roll_deg * (2.0 * (i % 3) as f64 / 2.0 - 1.0)).to_radians();
                let rotation = nalgebra::Rotation3::from_axis_angle(&nalgebra::Vector3::z_axis(), roll)
                    * nalgebra::Rotation3::from_axis_angle(&nalgebra::Vector3::y_axis(), -a);
                Rigid3::from_rotation_center(rotation.into_inner(), nalgebra::Vector3::new(-6.0 * a.sin(), 0.0, -6.0 * a.cos()))
            })
            .collect();
        let points_world: Vec<[f64; 3]> = (0..60)
            .map(|j| {
                let s = j as f64;
                [(s * 0.7).sin() * 2.5, (s * 1.3).cos() * 2.0, (s * 0.4).sin() * 2.5]
            })
            .collect();
        let mut observations = Vec::new();
        for (image, pose) in images.iter().enumerate() {
            for (point, p) in points_world.iter().enumerate() {
                let pixel = pixel_from_world(&camera, pose, p).expect("in front");
                observations.push(Observation { image, point, pixel });
            }
        }
        let mut image_fixed = vec![false; n];
        image_fixed[0] = true;
        let point_fixed = vec![false; points_world.len()];
        Problem {
            cameras: vec![camera],
            images,
            image_camera: vec![0; n],
            image_fixed,
            points_world,
            point_fixed,
            observations,
            priors: Vec::new(),
            held_intrinsics: Vec::new(),
        }
    }

    fn options(refine_principal_point: bool) -> Options {
        Options { loss: crate::Loss::Squared, refine_focal: true, refine_principal_point, ..Options::default() }
    }

    #[test]
    fn a_wide_ring_fixes_the_principal_point_and_a_narrow_arc_does_not() {
        let principal =
            |problem: &Problem, options: &Options, noise_px: f64| intrinsics_std(problem, options, noise_px).unwrap()[0].principal_point_px;
        let wide = principal(&arc_problem(12, 120.0, 30.0), &options(true), 1.0).unwrap();
        let narrow = principal(&arc_problem(3, 10.0, 0.0), &options(true), 1.0).unwrap();
        println!("principal point std: wide arc {wide:.3} px, narrow {narrow:.3} px");
        assert!(wide < 1.0, "wide arc: {wide} px");
        assert!(narrow > 10.0 * wide, "narrow arc {narrow} px, wide {wide} px");
        // Linear in the noise; nothing when the principal point is not refined.
        let twice = principal(&arc_problem(12, 120.0, 30.0), &options(true), 2.0).unwrap();
        assert!((twice - 2.0 * wide).abs() < 1e-9 * wide.max(1.0), "{twice} vs {wide}");
        assert_eq!(principal(&arc_problem(12, 120.0, 30.0), &options(false), 1.0), None);
    }
}
