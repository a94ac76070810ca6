//! The keyframes: every `kappa`-th frame of every camera, their SIFT features (kept in the
//! work folder under `features/`) and the verified matches of every pair of them. Their
//! reconstruction is [`crate::mapping::keyframe_model`].

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use rayon::prelude::*;

use dynview_core::StageProgress;
use dynview_core::fsutil::write_atomic;

use crate::error::{SfmError, SfmResult};
use crate::features::matching::{MatchOptions, TwoView, build_indices, mutual_matches_shared, verify};
use crate::features::sift::{FeatureOptions, Features};
use crate::input::frames::EventFrames;
use crate::work::WorkDir;

/// A keyframe: camera index and frame index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Keyframe {
    /// Camera (index into the event's cameras).
    pub camera: usize,
    /// Frame (time step).
    pub frame: usize,
}

/// The frames every `interval` frames, in camera-then-time order.
pub fn keyframes(frames: &EventFrames, interval: usize) -> Vec<Keyframe> {
    let n = frames.frame_count();
    (0..frames.cameras.len()).flat_map(|camera| (0..n).step_by(interval.max(1)).map(move |frame| Keyframe { camera, frame })).collect()
}

/// Path of a frame's feature file in the work folder.
pub fn feature_path(work: &WorkDir, frames: &EventFrames, k: Keyframe) -> std::path::PathBuf {
    let c = &frames.cameras[k.camera];
    work.join(format!("features/{}/{}.sift", c.name, c.file_name(k.frame)))
}

/// Extracts (or loads) the features of `keys`.
pub fn keyframe_features(
    work: &WorkDir,
    frames: &EventFrames,
    keys: &[Keyframe],
    options: &FeatureOptions,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<Vec<Features>> {
    let done = AtomicU64::new(0);
    let stamp = serde_json::to_string(options).unwrap_or_default();
    keys.par_iter()
        .map(|&k| {
            SfmError::check_interrupt(interrupt)?;
            let path = feature_path(work, frames, k);
            let stamp_path = path.with_extension("sift.options");
            let cached = std::fs::read_to_string(&stamp_path).is_ok_and(|s| s == stamp);
            let features = match cached.then(|| Features::read(&path)).transpose() {
                Ok(Some(f)) => f,
                _ => {
                    let f = crate::features::sift::extract_file(&frames.cameras[k.camera].files[k.frame], options)?;
                    f.write(&path)?;
                    write_atomic(&stamp_path, stamp.as_bytes()).map_err(SfmError::io(&stamp_path))?;
                    f
                }
            };
            progress("features", done.fetch_add(1, Ordering::Relaxed) + 1, keys.len() as u64);
            Ok(features)
        })
        .collect()
}

/// Matches and verifies every pair of `features`.
pub fn match_all_pairs(
    features: &[Features],
    options: &MatchOptions,
    progress: StageProgress,
    interrupt: &AtomicBool,
) -> SfmResult<Vec<(usize, usize, TwoView)>> {
    let mats = features.iter().map(Features::descriptor_mat).collect::<SfmResult<Vec<_>>>()?;
    let indices = build_indices(&mats)?;
    let pairs: Vec<(usize, usize)> = (0..features.len()).flat_map(|a| (a + 1..features.len()).map(move |b| (a, b))).collect();
    let done = AtomicU64::new(0);
    let verified: Vec<(usize, usize, TwoView)> = pairs
        .par_iter()
        .map(|&(a, b)| {
            SfmError::check_interrupt(interrupt)?;
            let matches = mutual_matches_shared(&mats, &indices, a, b, options)?;
            let two_view = verify(&features[a].xy, &features[b].xy, &matches, options)?;
            progress("matching", done.fetch_add(1, Ordering::Relaxed) + 1, pairs.len() as u64);
            Ok((a, b, two_view))
        })
        .collect::<SfmResult<Vec<_>>>()?;
    Ok(verified.into_iter().filter(|(_, _, v)| !v.inliers.is_empty()).collect())
}
