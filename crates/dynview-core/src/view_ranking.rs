//! Input view selection (paper Eq. rF).

use crate::camera::Rigid3;
use crate::rotation::relative_angle_rad;

/// Squared distances below this (in m^2) count as this, so a virtual camera placed exactly on
/// an input camera ranks it first instead of dividing by zero.
const MIN_CENTER_DISTANCE_SQ_M2: f64 = 1e-12;

/// The paper's ranking score of input camera `input_from_world` for the virtual camera
/// `virtual_from_world` (paper Eq. rF):
/// `r_F = 1 / ||C_t - C_s||^2 * exp(-theta / (2 pi sigma^2))`, where `theta` is the angle of
/// `R_t R_s^T`. Larger is better.
pub fn view_score(virtual_from_world: &Rigid3, input_from_world: &Rigid3, sigma: f64) -> f64 {
    let c_virtual = virtual_from_world.camera_center_world();
    let c_input = input_from_world.camera_center_world();
    let dist_sq = (c_virtual - c_input).length_squared().max(MIN_CENTER_DISTANCE_SQ_M2);
    let theta = relative_angle_rad(virtual_from_world.rotation, input_from_world.rotation);
    (-theta / (2.0 * std::f64::consts::PI * sigma * sigma)).exp() / dist_sq
}

/// Indices of the `n` best input cameras for the virtual camera, best first (ties keep the
/// input order). Returns fewer than `n` when there are fewer inputs.
pub fn rank_views(virtual_from_world: &Rigid3, inputs_from_world: &[Rigid3], sigma: f64, n: usize) -> Vec<usize> {
    let mut scored: Vec<(usize, f64)> =
        inputs_from_world.iter().enumerate().map(|(i, input)| (i, view_score(virtual_from_world, input, sigma))).collect();
    // Stable sort, descending score; NaN (never produced for valid poses) sorts last.
    scored.sort_by(|a, b| b.1.partial_cmp(&a.1).unwrap_or(std::cmp::Ordering::Less));
    scored.into_iter().take(n).map(|(i, _)| i).collect()
}

/// Smallest weight of a chosen view in the color initial guess, relative to the best view's
/// rank score: a view whose score is negligible next to the best one's still counts a little,
/// so a pixel only that view sees takes its color rather than the fallback.
pub const MIN_RELATIVE_BLEND_WEIGHT: f64 = 1e-6;

/// The input views chosen for a virtual camera and their weights in the color initial guess.
#[derive(Clone, Debug, PartialEq)]
pub struct ChosenViews {
    /// Indices of the chosen inputs, best first (as [`rank_views`]).
    pub indices: Vec<usize>,
    /// Per chosen view: its rank score `r_F` relative to the best, at least
    /// [`MIN_RELATIVE_BLEND_WEIGHT`] (the weights of the visibility-tested blend).
    pub blend_weights: Vec<f32>,
}

/// How the chosen views are weighed against the best one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RankTolerance {
    /// The angular tolerance `sigma` of the score `r_F` ([`view_score`]).
    pub sigma: f64,
    /// A chosen view turned more than this (radians) beyond the best view's angle to the
    /// virtual camera keeps only [`MIN_RELATIVE_BLEND_WEIGHT`], whatever its score: it sees
    /// other sides of the scene, and counts only where no nearer view sees. `PI` or more: no cap.
    pub max_extra_angle_rad: f64,
}

/// The `n` best input cameras for the virtual camera (as [`rank_views`]) with their weights in
/// the color initial guess (as [`ChosenViews::blend_weights`]); the CPU and GPU renderers
/// both start from these.
pub fn choose_views(virtual_from_world: &Rigid3, inputs_from_world: &[Rigid3], tolerance: RankTolerance, n: usize) -> ChosenViews {
    let indices = rank_views(virtual_from_world, inputs_from_world, tolerance.sigma, n);
    let scores: Vec<f64> = indices.iter().map(|&s| view_score(virtual_from_world, &inputs_from_world[s], tolerance.sigma)).collect();
    let angles: Vec<f64> =
        indices.iter().map(|&s| relative_angle_rad(virtual_from_world.rotation, inputs_from_world[s].rotation)).collect();
    let best = scores.iter().copied().fold(f64::MIN_POSITIVE, f64::max);
    let best_angle = angles.first().copied().unwrap_or(0.0);
    let blend_weights = scores
        .iter()
        .zip(&angles)
        .map(|(s, angle)| {
            let relative = if angle - best_angle > tolerance.max_extra_angle_rad { 0.0 } else { s / best };
            relative.max(MIN_RELATIVE_BLEND_WEIGHT) as f32
        })
        .collect();
    ChosenViews { indices, blend_weights }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat3, DVec3};

    const PAPER: RankTolerance = RankTolerance { sigma: 0.075, max_extra_angle_rad: std::f64::consts::PI };

    fn looking_at_origin(eye: DVec3) -> Rigid3 {
        Rigid3::camera_from_world_looking_at(eye, DVec3::ZERO, DVec3::Y)
    }

    #[test]
    fn score_hand_checked() {
        // Same orientation, 2 m apart: score = 1/4.
        let a = Rigid3::new(DMat3::IDENTITY, DVec3::ZERO);
        let b = Rigid3::new(DMat3::IDENTITY, DVec3::new(-2.0, 0.0, 0.0));
        assert!((view_score(&a, &b, 0.075) - 0.25).abs() < 1e-15);
        // Rotated by 0.1 rad about y at the same distance: 1/4 * exp(-0.1 / (2 pi 0.075^2)).
        let c = Rigid3::new(DMat3::from_rotation_y(0.1), DMat3::from_rotation_y(0.1) * DVec3::new(-2.0, 0.0, 0.0));
        let expected = 0.25 * (-0.1 / (2.0 * std::f64::consts::PI * 0.075 * 0.075)).exp();
        assert!((view_score(&a, &c, 0.075) - expected).abs() < 1e-12);
    }

    #[test]
    fn nearest_similar_views_rank_first() {
        let inputs: Vec<Rigid3> = (-3..=3)
            .map(|i| {
                let angle = f64::from(i) * 10f64.to_radians();
                looking_at_origin(DVec3::new(6.0 * angle.sin(), 1.5, 6.0 * angle.cos()))
            })
            .collect();
        // A virtual camera between inputs 4 (+10 deg) and 5 (+20 deg), closer to 4.
        let angle = 13f64.to_radians();
        let virtual_cam = looking_at_origin(DVec3::new(6.0 * angle.sin(), 1.5, 6.0 * angle.cos()));
        let ranked = rank_views(&virtual_cam, &inputs, 0.075, 4);
        assert_eq!(ranked, vec![4, 5, 3, 6]);
    }

    #[test]
    fn blend_weights_are_scores_relative_to_the_best() {
        let inputs: Vec<Rigid3> = [0.0, 0.5, 40.0].iter().map(|&x| looking_at_origin(DVec3::new(x, 0.0, 5.0))).collect();
        let virtual_cam = looking_at_origin(DVec3::new(0.2, 0.0, 5.0));
        let chosen = choose_views(&virtual_cam, &inputs, PAPER, 3);
        assert_eq!(chosen.indices, rank_views(&virtual_cam, &inputs, 0.075, 3));
        assert_eq!(chosen.blend_weights[0], 1.0);
        let score = |k: usize| view_score(&virtual_cam, &inputs[chosen.indices[k]], 0.075);
        assert_eq!(chosen.blend_weights[1], (score(1) / score(0)) as f32);
        assert!(chosen.blend_weights[1] > 1e3 * MIN_RELATIVE_BLEND_WEIGHT as f32);
        // The far, turned view's score is negligible: it keeps the floor.
        assert_eq!(chosen.blend_weights[2], MIN_RELATIVE_BLEND_WEIGHT as f32);
    }

    #[test]
    fn views_turned_beyond_the_cap_keep_only_the_floor() {
        // Inputs on a ring around the origin at 0, 20 and 80 degrees; the virtual camera at 5.
        let on_ring = |deg: f64| {
            let a = deg.to_radians();
            looking_at_origin(DVec3::new(6.0 * a.sin(), 0.0, 6.0 * a.cos()))
        };
        let inputs: Vec<Rigid3> = [0.0, 20.0, 80.0].iter().map(|&d| on_ring(d)).collect();
        let virtual_cam = on_ring(5.0);
        let wide = RankTolerance { sigma: 1.0, max_extra_angle_rad: std::f64::consts::PI };
        let uncapped = choose_views(&virtual_cam, &inputs, wide, 3);
        assert_eq!(uncapped.indices, vec![0, 1, 2]);
        assert!(
            uncapped.blend_weights[2] > 1e3 * MIN_RELATIVE_BLEND_WEIGHT as f32,
            "a wide tolerance keeps the 80-degree view: {:?}",
            uncapped.blend_weights
        );
        // Capped at 30 degrees beyond the best (5 degrees away): the 20-degree view (15 beyond)
        // keeps its score, the 80-degree view (75 beyond) only the floor.
        let capped = choose_views(&virtual_cam, &inputs, RankTolerance { max_extra_angle_rad: 30f64.to_radians(), ..wide }, 3);
        assert_eq!(capped.indices, uncapped.indices);
        assert_eq!(capped.blend_weights[..2], uncapped.blend_weights[..2]);
        assert_eq!(capped.blend_weights[2], MIN_RELATIVE_BLEND_WEIGHT as f32);
    }

    #[test]
    fn coincident_camera_ranks_first_and_n_caps() {
        let inputs = vec![looking_at_origin(DVec3::new(0.0, 0.0, 5.0)), looking_at_origin(DVec3::new(1.0, 0.0, 5.0))];
        let ranked = rank_views(&inputs[1], &inputs, 0.075, 4);
        assert_eq!(ranked, vec![1, 0]);
        assert!(view_score(&inputs[1], &inputs[1], 0.075).is_finite());
    }
}
