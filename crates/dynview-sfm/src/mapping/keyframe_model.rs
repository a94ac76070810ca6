//! The keyframe stage's reconstruction: initial intrinsics (given, self-calibrated or the
//! prior), cameras that stand still pooled ([`crate::mapping::still`]), the incremental
//! reconstruction ([`crate::mapping::incremental`]), what the report says of the intrinsics,
//! and the model as COLMAP text (saved to `work/keyframes/`, with our model as JSON).

use std::sync::atomic::AtomicBool;

use dynview_ba::HeldIntrinsics;
use dynview_camera::{Model, Radial};
use dynview_core::StageProgress;
use dynview_core::fsutil::write_atomic;
use dynview_interchange::colmap::{ColmapCamera, ColmapImage, ColmapModel, ColmapPoint3D, Point2D};

use nalgebra::Vector3;

use crate::error::{SfmError, SfmResult};
use crate::estimators::focal::{PRIOR_FOCAL_FACTOR, PairGeometry, estimate_focal_factor};
use crate::features::matching::{MatchOptions, TwoView};
use crate::features::sift::Features;
use crate::input::calibration::{KnownCameras, held_intrinsics};
use crate::input::frames::{CameraFrames, EventFrames};
use crate::mapping::incremental::{MapImage, MapperOptions, PRINCIPAL_POINT_PRIOR_FRACTION, Reconstruction, reconstruct};
use crate::mapping::keyframes::Keyframe;
use crate::mapping::refine::{CameraTrack, KeyframeView};
use crate::mapping::still::{cameras_to_pool, pool, still_cameras, unpool, without_pairs_across_time};

/// The keyframe stage's result.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct KeyframeModel {
    /// The keyframes, in image order of the reconstruction.
    pub keyframes: Vec<Keyframe>,
    /// The reconstruction.
    pub reconstruction: Reconstruction,
    /// How the focal lengths were initialised, per camera.
    pub focal_source: Vec<String>,
    /// Per camera, whether it stands still (`still`): one pose for all its frames.
    #[serde(default)]
    pub still_cameras: Vec<bool>,
}

impl KeyframeModel {
    /// The keyframes as the reconstruction's images (physical camera and feature positions).
    pub fn map_images(&self, features: &[Features]) -> Vec<MapImage> {
        self.keyframes.iter().zip(features).map(|(k, f)| MapImage { camera: k.camera, xy: f.xy.clone() }).collect()
    }
}

/// [`KeyframeModel::focal_source`] of a camera whose focal length nothing measured: no pair
/// self-calibrated and none was given (later notes are appended to it).
pub const PRIOR_FOCAL_SOURCE: &str = "prior (1.2 x longer side)";

/// How a focal length self-calibrated from the keyframe pairs' fundamental matrices begins its
/// source. Such a start is solved a second time from the prior and the reconstruction that
/// registers more keyframe images (then explains more observations) is kept: on five
/// unsynchronized synthetic phones on tripods (640x360, 45 frames, keyframes every 10 frames)
/// self-calibration gave 0.309 x the longer side (the truth 0.733) and the reconstruction kept
/// that basin (focal lengths 214-247 px against 469, 22 of 25 keyframes registered); from the
/// prior all 25 register and the focal lengths come out within 1%.
pub const SELF_CALIBRATED_SOURCE: &str = "self-calibrated";

/// The prior's intrinsics for a camera: the focal length 1.2 x the longer side, centred.
fn prior_intrinsics(camera: &CameraFrames) -> Radial {
    let longer = f64::from(camera.width.max(camera.height));
    Radial::centred(PRIOR_FOCAL_FACTOR * longer, camera.width, camera.height)
}

/// How well a reconstruction fits its keyframes, compared lexicographically: the images it
/// registered, then the observations its points explain.
fn fit_rank(reconstruction: &Reconstruction) -> (usize, usize) {
    let registered = reconstruction.poses.iter().filter(|p| p.is_some()).count();
    let observations = reconstruction.points.iter().map(|p| p.observations.len()).sum();
    (registered, observations)
}

/// Initial intrinsics per camera: the known ones, else self-calibration, else the prior.
pub fn initial_intrinsics(
    frames: &EventFrames,
    keys: &[Keyframe],
    pairs: &[(usize, usize, TwoView)],
    known: &KnownCameras,
    match_options: &MatchOptions,
) -> (Vec<Radial>, Vec<String>) {
    // Frames of one camera may share no baseline; use pairs of two cameras when there are any,
    // and only pairs a homography does not explain (a dominant plane leaves F ill-determined).
    let across = pairs.iter().any(|(a, b, _)| keys[*a].camera != keys[*b].camera);
    let geometry: Vec<PairGeometry> = pairs
        .iter()
        .filter(|(a, b, v)| (!across || keys[*a].camera != keys[*b].camera) && !v.is_degenerate(match_options))
        .filter_map(|(a, b, v)| {
            let (ca, cb) = (&frames.cameras[keys[*a].camera], &frames.cameras[keys[*b].camera]);
            Some(PairGeometry {
                fundamental: v.fundamental?,
                size_a: (ca.width, ca.height),
                size_b: (cb.width, cb.height),
                inliers: v.inliers.len(),
            })
        })
        .collect();
    let estimated = estimate_focal_factor(&geometry);
    frames
        .cameras
        .iter()
        .map(|c| {
            let longer = f64::from(c.width.max(c.height));
            match (known.get(&c.name), estimated) {
                (Some(k), _) => (k.intrinsics, if k.calibrated { "given (calibration)" } else { "given" }.to_string()),
                (None, Some(factor)) => {
                    (Radial::centred(factor * longer, c.width, c.height), format!("{SELF_CALIBRATED_SOURCE} ({factor:.3} x {longer})"))
                }
                (None, None) => (prior_intrinsics(c), PRIOR_FOCAL_SOURCE.to_string()),
            }
        })
        .unzip()
}

/// Runs the reconstruction of the keyframes.
#[allow(clippy::too_many_arguments)]
pub fn reconstruct_keyframes(
    frames: &EventFrames,
    keys: &[Keyframe],
    features: &[Features],
    pairs: &[(usize, usize, TwoView)],
    known: &KnownCameras,
    match_options: &MatchOptions,
    mapper_options: &MapperOptions,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<KeyframeModel> {
    let still = still_cameras(frames.cameras.len(), keys, features, pairs);
    let pairs = &without_pairs_across_time(&still, keys, pairs);
    let pooled_cameras = cameras_to_pool(&still, keys, pairs);
    let pooled = pool(keys, features, pairs, &pooled_cameras, match_options)?;
    let (intrinsics, mut focal_source) = initial_intrinsics(frames, &pooled.keys, &pooled.pairs, known, match_options);
    let group = intrinsics_groups(frames, known, mapper_options.share_intrinsics);
    let images: Vec<MapImage> =
        pooled.keys.iter().zip(&pooled.features).map(|(k, f)| MapImage { camera: group[k.camera], xy: f.xy.clone() }).collect();
    let solve = |intrinsics: &[Radial]| {
        let (group_intrinsics, group_held) = per_group(frames, known, &group, intrinsics);
        reconstruct(&images, &pooled.pairs, group_intrinsics, group_held, match_options, mapper_options, progress, interrupt)
    };
    let solved = solve(&intrinsics);
    let solved = again_from_the_prior(frames, &intrinsics, &mut focal_source, solved, solve);
    let reconstruction = solved.map_err(|e| match e {
        SfmError::Reconstruction(message) if pooled.untrusted_pairs > 0 => SfmError::Reconstruction(format!(
            "{message}; {} pairs of cameras that stand still were matched on their static background alone, which repeated structure \
                 can match wrongly at every time step, and were not trusted",
            pooled.untrusted_pairs
        )),
        e => e,
    })?;
    let mut reconstruction = unpool(&pooled, reconstruction);
    for restart in &reconstruction.focal_restarts {
        for (source, _) in focal_source.iter_mut().zip(&group).filter(|(_, g)| **g == restart.camera) {
            source.push_str(&format!(
                "; its focal length had settled at {:.1} px, {:+.0}% from the other cameras' median, and fits the keyframes better solved again from there",
                restart.settled_px,
                100.0 * (restart.settled_px / restart.restarted_px - 1.0)
            ));
        }
    }
    reconstruction.intrinsics = group.iter().map(|&g| reconstruction.intrinsics[g]).collect();
    for (c, source) in focal_source.iter_mut().enumerate() {
        let sharing = group.iter().filter(|&&g| g == group[c]).count();
        if sharing > 1 {
            source.push_str(&format!("; shared by the {sharing} cameras of this image size"));
        }
    }
    for (c, source) in focal_source.iter_mut().enumerate().filter(|(c, _)| still[*c]) {
        source.push_str(if pooled_cameras[c] {
            "; camera stands still: its keyframes pooled into one image"
        } else {
            "; camera stands still (its keyframes match others well enough alone: not pooled)"
        });
    }
    Ok(KeyframeModel { keyframes: keys.to_vec(), reconstruction, focal_source, still_cameras: still })
}

/// Where self-calibration started some focal lengths, solves again with those at the prior and
/// keeps the reconstruction that fits the keyframes better ([`fit_rank`]; see
/// `SELF_CALIBRATED_SOURCE`), noting a switch in their `focal_source`.
fn again_from_the_prior(
    frames: &EventFrames,
    intrinsics: &[Radial],
    focal_source: &mut [String],
    solved: SfmResult<Reconstruction>,
    solve: impl Fn(&[Radial]) -> SfmResult<Reconstruction>,
) -> SfmResult<Reconstruction> {
    let self_calibrated = |source: &String| source.starts_with(SELF_CALIBRATED_SOURCE);
    if !focal_source.iter().any(self_calibrated) {
        return solved;
    }
    let prior: Vec<Radial> = frames
        .cameras
        .iter()
        .zip(intrinsics)
        .zip(focal_source.iter())
        .map(|((c, k), source)| if self_calibrated(source) { prior_intrinsics(c) } else { *k })
        .collect();
    let Ok(from_prior) = solve(&prior) else { return solved };
    let (registered, observations) = fit_rank(&from_prior);
    let against = match &solved {
        Ok(from_self) if fit_rank(from_self) >= (registered, observations) => return solved,
        Ok(from_self) => {
            let (self_registered, self_observations) = fit_rank(from_self);
            format!("{self_registered} and {self_observations}")
        }
        Err(e) => format!("a failure: {e}"),
    };
    for source in focal_source.iter_mut().filter(|s| self_calibrated(s)) {
        *source = format!(
            "{PRIOR_FOCAL_SOURCE}, where the {source} start fit the keyframes worse ({registered} keyframe images \
             registered and {observations} observations explained from the prior, against {against})"
        );
    }
    Ok(from_prior)
}

/// Standard deviation of a refined focal length, as a share of it, above which prep warns that
/// the views hardly fix it: errors of two or three times this bend the whole model visibly.
/// Measured: 0.54-0.70% on the synthetic arcs, 0.86-1.72% on the temple ring's 16 views as 16
/// one-frame cameras (errors up to 2.8%).
pub const WEAK_FOCAL_FRACTION: f64 = 0.02;

/// A warning per camera whose refined focal length the views fix only to more than
/// [`WEAK_FOCAL_FRACTION`] (one standard deviation, `std_percent` per camera), naming the
/// camera and the `--focal` argument that would fix it.
pub fn weak_focal_warnings(frames: &EventFrames, intrinsics: &[Radial], std_percent: &[Option<f64>]) -> Vec<String> {
    frames
        .cameras
        .iter()
        .zip(intrinsics)
        .zip(std_percent)
        .filter_map(|((camera, k), std)| {
            let fraction = (*std)? / 100.0;
            (fraction > WEAK_FOCAL_FRACTION).then(|| {
                format!(
                    "camera {}: its views fix its focal length ({:.0} px) only to {:.1}% (one standard deviation), which bends the model; if \
                     it is known, give it with --focal {}=PX",
                    camera.name,
                    k.f,
                    100.0 * fraction,
                    camera.name
                )
            })
        })
        .collect()
}

/// Per camera, the standard deviation of its refined focal length as a share of it; `None`
/// where the focal was given or not measured.
pub fn focal_std_fractions(frames: &EventFrames, model: &KeyframeModel, known: &KnownCameras, options: &MapperOptions) -> Vec<Option<f64>> {
    let group = intrinsics_groups(frames, known, options.share_intrinsics);
    let r = &model.reconstruction;
    (0..frames.cameras.len()).map(|c| Some(r.focal_std_px.get(group[c]).copied().flatten()? / r.intrinsics.get(c)?.f)).collect()
}

/// Per camera, which intrinsics the keyframe reconstruction refined and why (the report's
/// `intrinsics_refined`), from the options it ran with.
pub fn intrinsics_notes(frames: &EventFrames, model: &KeyframeModel, known: &KnownCameras, options: &MapperOptions) -> Vec<String> {
    let group = intrinsics_groups(frames, known, options.share_intrinsics);
    let r = &model.reconstruction;
    let std_of = |c: usize| r.principal_point_std_px.get(group[c]).copied().flatten();
    let worst = (0..frames.cameras.len()).filter_map(|c| std_of(c).map(|s| (s, c))).max_by(|a, b| a.0.total_cmp(&b.0));
    let focal_std = focal_std_fractions(frames, model, known, options);
    (0..frames.cameras.len())
        .map(|c| {
            let g = group[c];
            let held = held_intrinsics(known, &frames.cameras[c].name);
            let focal = match focal_std[c].map(|fraction| 100.0 * fraction) {
                _ if held.focal => "focal kept as given".to_string(),
                _ if !options.refine_focal => "focal kept as estimated before bundle adjustment (as asked)".to_string(),
                Some(percent) => format!("focal refined (known to {percent:.2}%)"),
                None => "focal refined".to_string(),
            };
            let principal = match (std_of(c), worst) {
                _ if held.principal_point => "principal point kept as given".to_string(),
                _ if !options.refine_principal_point => "principal point kept at the image centre (as asked)".to_string(),
                (Some(s), _) if r.principal_point_refined => format!("principal point refined (known to {s:.2} px)"),
                (Some(s), _) if s.is_infinite() => {
                    "principal point kept at the image centre: the data do not fix it (the normal equations with it refined are singular)".to_string()
                }
                (Some(s), Some((w, worst_camera))) => format!(
                    "principal point kept at the image centre: the data fix it to {s:.2} px here and {w:.2} px at worst ({}), not better than principal points usually lie from the centre ({:.1}% of the longer side)",
                    frames.cameras[worst_camera].name,
                    100.0 * PRINCIPAL_POINT_PRIOR_FRACTION
                ),
                _ => "principal point kept at the image centre (not measured: no registered keyframe)".to_string(),
            };
            let sharing: Vec<&str> = (0..frames.cameras.len()).filter(|&o| o != c && group[o] == g).map(|o| frames.cameras[o].name.as_str()).collect();
            let shared = if sharing.is_empty() { String::new() } else { format!("; shared with {}", sharing.join(", ")) };
            format!("{focal}, {principal}{shared}")
        })
        .collect()
}

/// Per intrinsics set (`group`, from [`intrinsics_groups`]): its intrinsics, taken from
/// `per_camera` at the set's first camera, and what the user gave for it (the cameras of one set
/// are all given alike or not at all).
pub fn per_group(frames: &EventFrames, known: &KnownCameras, group: &[usize], per_camera: &[Radial]) -> (Vec<Radial>, Vec<HeldIntrinsics>) {
    let sets = group.iter().max().map_or(0, |g| g + 1);
    let first: Vec<usize> = (0..sets).map(|g| group.iter().position(|&x| x == g).unwrap_or(0)).collect();
    (first.iter().map(|&c| per_camera[c]).collect(), first.iter().map(|&c| held_intrinsics(known, &frames.cameras[c].name)).collect())
}

/// Which intrinsics each camera uses: with `share`, cameras of equal image size without
/// different known intrinsics share one set (one camera model filmed everything), else one each.
pub fn intrinsics_groups(frames: &EventFrames, known: &KnownCameras, share: bool) -> Vec<usize> {
    if !share {
        return (0..frames.cameras.len()).collect();
    }
    // Groups are numbered in order of first appearance.
    let mut keys: Vec<(u32, u32, Option<[u64; 3]>)> = Vec::new();
    frames
        .cameras
        .iter()
        .map(|camera| {
            let key = (
                camera.width,
                camera.height,
                known.get(&camera.name).map(|k| [k.intrinsics.f, k.intrinsics.cx, k.intrinsics.cy].map(f64::to_bits)),
            );
            keys.iter().position(|k| *k == key).unwrap_or_else(|| {
                keys.push(key);
                keys.len() - 1
            })
        })
        .collect()
}

/// The keyframe model as a COLMAP model (RADIAL cameras, image names `<camera>/<file>`, all
/// features as 2D points, point errors as mean reprojection errors).
pub fn to_colmap(model: &KeyframeModel, frames: &EventFrames, features: &[Features]) -> ColmapModel {
    let mut out = ColmapModel::default();
    let r = &model.reconstruction;
    for (c, camera) in frames.cameras.iter().enumerate() {
        let k = r.intrinsics[c];
        // COLMAP puts pixel centres at +0.5.
        let colmap = Radial { cx: k.cx + 0.5, cy: k.cy + 0.5, ..k };
        out.cameras.insert(
            c as u32 + 1,
            ColmapCamera { model: Radial::MODEL, width: camera.width, height: camera.height, params: colmap.params() },
        );
    }
    let point_of = model.feature_points(features);
    for (i, key) in model.keyframes.iter().enumerate() {
        let Some(pose) = &r.poses[i] else { continue };
        let camera = &frames.cameras[key.camera];
        let points2d = features[i]
            .xy
            .iter()
            .zip(&point_of[i])
            .map(|(xy, p)| Point2D { xy: [f64::from(xy[0]) + 0.5, f64::from(xy[1]) + 0.5], point3d_id: p.map(|p| u64::from(p) + 1) })
            .collect();
        out.images.insert(
            i as u32 + 1,
            ColmapImage {
                camera_id: key.camera as u32 + 1,
                camera_from_world: *pose,
                name: format!("{}/{}", camera.name, camera.file_name(key.frame)),
                points2d,
            },
        );
    }
    let images = model.map_images(features);
    let poses = r.pose_matrices();
    for (p, point) in r.points.iter().enumerate() {
        let errors = r.point_errors_px(&images, &poses, point);
        let error = errors.iter().sum::<f64>() / errors.len().max(1) as f64;
        out.points3d.insert(
            p as u64 + 1,
            ColmapPoint3D {
                xyz: point.xyz.into(),
                rgb: [128, 128, 128],
                error,
                track: point.observations.iter().map(|&(i, f)| (i as u32 + 1, f)).collect(),
            },
        );
    }
    out
}

/// Writes a COLMAP text model into `dir` (each file atomically).
pub fn write_colmap_text(model: &ColmapModel, dir: &std::path::Path) -> SfmResult<()> {
    for (name, text) in [("cameras.txt", model.cameras_txt()), ("images.txt", model.images_txt()), ("points3D.txt", model.points3d_txt())] {
        let path = dir.join(name);
        write_atomic(&path, text.as_bytes()).map_err(SfmError::io(&path))?;
    }
    Ok(())
}

impl KeyframeModel {
    /// Per keyframe, the model point each of its `features` sees, if any
    /// (`Reconstruction::point_of_feature`).
    pub fn feature_points(&self, features: &[Features]) -> Vec<Vec<Option<u32>>> {
        let counts: Vec<usize> = features.iter().map(Features::len).collect();
        self.reconstruction.point_of_feature(&counts)
    }

    /// The model's points, in the world.
    pub fn points_world(&self) -> Vec<Vector3<f64>> {
        self.reconstruction.points.iter().map(|p| p.xyz).collect()
    }

    /// Camera `c` (`camera`, its frames) as the frame-to-frame refinement takes it: its frames,
    /// its keyframe model intrinsics, and each registered keyframe's pose, features and points
    /// (`point_of`: [`Self::feature_points`]; `points_world`: [`Self::points_world`]).
    /// `None` when none of its keyframes is registered.
    pub fn camera_track<'a>(
        &self,
        camera: &'a CameraFrames,
        c: usize,
        features: &'a [Features],
        point_of: &[Vec<Option<u32>>],
        points_world: &'a [Vector3<f64>],
    ) -> Option<CameraTrack<'a>> {
        let r = &self.reconstruction;
        let mut keyframes = vec![None; camera.files.len()];
        for (i, k) in self.keyframes.iter().enumerate() {
            if k.camera == c
                && k.frame < keyframes.len()
                && let Some(pose) = r.poses[i]
            {
                keyframes[k.frame] = Some(KeyframeView { pose, features: &features[i], point_of_feature: point_of[i].clone() });
            }
        }
        keyframes.iter().any(Option::is_some).then(|| CameraTrack {
            name: &camera.name,
            files: &camera.files,
            intrinsics: r.intrinsics[c],
            keyframes,
            points_world,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::frames::CameraFrames;

    #[test]
    fn a_focal_the_views_hardly_fix_is_named_with_the_argument_that_fixes_it() {
        let camera = |name: &str| CameraFrames { name: name.into(), width: 640, height: 360, files: Vec::new() };
        let frames = EventFrames { cameras: vec![camera("left"), camera("middle"), camera("right")] };
        let intrinsics = vec![Radial::centred(500.0, 640, 360); 3];
        // Known to 3%, to 0.5%, and given (no standard deviation).
        let warnings = weak_focal_warnings(&frames, &intrinsics, &[Some(3.0), Some(0.5), None]);
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert!(warnings[0].starts_with("camera left: ") && warnings[0].contains("only to 3.0%"), "{}", warnings[0]);
        assert!(warnings[0].ends_with("--focal left=PX"), "{}", warnings[0]);
    }
}
