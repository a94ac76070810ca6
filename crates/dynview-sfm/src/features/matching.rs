//! Descriptor matching (ratio test and cross-check) and robust two-view verification
//! (OpenCV's USAC MAGSAC++ for the fundamental matrix and a homography).

use opencv::calib3d;
use opencv::core::{DMatch, Mat, Point2f, Vector};
use opencv::features2d::{BFMatcher, FlannBasedMatcher};
use opencv::prelude::*;

use crate::error::{SfmError, SfmResult};

/// How image pairs are matched and verified.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MatchOptions {
    /// Lowe's ratio: the best match must be closer than `ratio` times the second best.
    pub ratio: f32,
    /// Fewest geometrically verified matches for a pair to count.
    pub min_inliers: usize,
    /// MAGSAC++'s upper bound on the noise scale (px); MAGSAC marginalises over scales below it,
    /// so no fixed inlier threshold is set by hand.
    pub max_sigma_px: f64,
    /// RANSAC confidence.
    pub confidence: f64,
    /// A pair whose homography explains this share of the fundamental matrix's inliers is
    /// treated as having no usable baseline (tripod frames, pure rotation, a plane).
    pub homography_ratio: f64,
    /// Most descriptor comparisons (features of one image x the other's) for which a pair is
    /// matched exactly (brute force) rather than through FLANN's kd-trees
    /// ([`EXACT_MATCH_MAX_COMPARISONS`] by default; `usize::MAX`: every pair).
    #[serde(default = "default_exact_max_comparisons")]
    pub exact_max_comparisons: usize,
}

fn default_exact_max_comparisons() -> usize {
    EXACT_MATCH_MAX_COMPARISONS
}

impl Default for MatchOptions {
    fn default() -> Self {
        Self {
            ratio: 0.8,
            min_inliers: 15,
            max_sigma_px: 3.0,
            confidence: 0.9999,
            homography_ratio: 0.85,
            exact_max_comparisons: EXACT_MATCH_MAX_COMPARISONS,
        }
    }
}

/// Verified matches of an image pair.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TwoView {
    /// Index pairs `(feature in a, feature in b)` consistent with the pair's geometry.
    pub inliers: Vec<[u32; 2]>,
    /// Inliers of the fundamental matrix.
    pub fundamental_inliers: usize,
    /// Inliers of the homography.
    pub homography_inliers: usize,
    /// The fundamental matrix (row-major, `x_b^T F x_a = 0`), when one was found.
    pub fundamental: Option<[f64; 9]>,
}

impl TwoView {
    /// Whether the homography explains nearly everything: no baseline to triangulate from.
    pub fn is_degenerate(&self, options: &MatchOptions) -> bool {
        self.homography_inliers as f64 >= options.homography_ratio * self.fundamental_inliers as f64
    }
}

/// Serialises the building of FLANN indices, which draw from the C library's global `rand()`
/// (and OpenCV's per-thread generator).
static FLANN_BUILD: std::sync::Mutex<()> = std::sync::Mutex::new(());
/// The seed of every FLANN index: the same descriptors always give the same matches, whatever
/// ran before on whichever thread (range runs must reproduce a whole run exactly).
pub const FLANN_SEED: u32 = 0x5eed;

/// A FLANN kd-tree index over one image's descriptors, built once and queried by any number
/// of other images.
pub struct DescriptorIndex {
    matcher: opencv::core::Ptr<FlannBasedMatcher>,
    len: usize,
    /// The descriptors, for exact matching where it is cheap ([`EXACT_MATCH_MAX_COMPARISONS`]).
    train: Mat,
}

/// The default of [`MatchOptions::exact_max_comparisons`]: most descriptor comparisons (query
/// rows x indexed rows) for which an image pair is matched exactly (brute force) rather than
/// through the kd-trees. FLANN's default search (32 checks) misses true nearest neighbours;
/// where exact matching is affordable it is used: on the Middlebury temple (1100-1600 features
/// an image) and the Panoptic arc it costs 0-3 s more per run and cuts the rotation error
/// (`docs/results/sfm.md`). 4 million comparisons is about 2000 features an image. Every pair
/// exact (`dynview prep --exact-matching`) is 4x slower on the 640x360 arcs, and more accurate.
pub const EXACT_MATCH_MAX_COMPARISONS: usize = 4_000_000;

impl DescriptorIndex {
    /// Builds the index of `train` (rows of descriptors), from [`FLANN_SEED`].
    pub fn build(train: &Mat) -> SfmResult<Self> {
        let mut matcher = FlannBasedMatcher::create().map_err(SfmError::cv("creating a matcher"))?;
        let _guard = FLANN_BUILD.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        // SAFETY: `srand` only sets the C library's random state; the lock keeps every index
        // build, the only user of that state here, from interleaving with another.
        #[allow(unsafe_code)]
        unsafe {
            libc::srand(FLANN_SEED)
        };
        // OpenCV's own generator (per thread) too, in case its FLANN draws from it.
        opencv::core::set_rng_seed(FLANN_SEED as i32).map_err(SfmError::cv("seeding OpenCV's generator"))?;
        let mut trains = Vector::<Mat>::new();
        trains.push(train.clone());
        opencv::prelude::FlannBasedMatcherTrait::add(&mut matcher, &trains).map_err(SfmError::cv("adding descriptors to a matcher"))?;
        opencv::prelude::FlannBasedMatcherTrait::train(&mut matcher).map_err(SfmError::cv("building a FLANN index"))?;
        Ok(Self { matcher, len: train.rows().max(0) as usize, train: train.clone() })
    }

    /// For each row of `query`, the index of its nearest neighbour here when it passes Lowe's
    /// ratio test against the second nearest; exact when the pair needs at most
    /// `exact_max_comparisons` comparisons, else through the kd-trees.
    pub fn nearest_passing_ratio(&mut self, query: &Mat, ratio: f32, exact_max_comparisons: usize) -> SfmResult<Vec<Option<u32>>> {
        if query.rows() < 1 || self.len < 2 {
            return Ok(vec![None; query.rows().max(0) as usize]);
        }
        let mut matches = Vector::new();
        if (query.rows() as usize).saturating_mul(self.len) <= exact_max_comparisons {
            let exact = BFMatcher::create(opencv::core::NORM_L2, false).map_err(SfmError::cv("creating an exact matcher"))?;
            exact.knn_train_match_def(query, &self.train, &mut matches, 2).map_err(SfmError::cv("exact knn matching"))?;
            return Ok(best_passing_ratio(&matches, ratio, self.len));
        }
        self.matcher.knn_match(query, &mut matches, 2, &Mat::default(), false).map_err(SfmError::cv("knn matching"))?;
        Ok(best_passing_ratio(&matches, ratio, self.len))
    }
}

/// Mutual nearest neighbours of two images whose indices are built, passing the ratio test both
/// ways: pairs `[row of a, row of b]`.
pub fn mutual_matches_indexed(
    a: (&Mat, &mut DescriptorIndex),
    b: (&Mat, &mut DescriptorIndex),
    options: &MatchOptions,
) -> SfmResult<Vec<[u32; 2]>> {
    let ab = b.1.nearest_passing_ratio(a.0, options.ratio, options.exact_max_comparisons)?;
    let ba = a.1.nearest_passing_ratio(b.0, options.ratio, options.exact_max_comparisons)?;
    Ok(mutual(&ab, &ba))
}

/// One index per descriptor matrix (built in parallel, serialised only where FLANN draws random
/// numbers), each behind a lock so that the pairs an image is in can share it across threads.
pub fn build_indices(mats: &[Mat]) -> SfmResult<Vec<std::sync::Mutex<DescriptorIndex>>> {
    use rayon::prelude::*;
    mats.par_iter().map(|m| DescriptorIndex::build(m).map(std::sync::Mutex::new)).collect()
}

/// [`mutual_matches_indexed`] with shared indices: images `a` and `b` of `mats` and `indices`.
pub fn mutual_matches_shared(
    mats: &[Mat],
    indices: &[std::sync::Mutex<DescriptorIndex>],
    a: usize,
    b: usize,
    options: &MatchOptions,
) -> SfmResult<Vec<[u32; 2]>> {
    let lock = |i: usize| indices[i].lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let ab = lock(b).nearest_passing_ratio(&mats[a], options.ratio, options.exact_max_comparisons)?;
    let ba = lock(a).nearest_passing_ratio(&mats[b], options.ratio, options.exact_max_comparisons)?;
    Ok(mutual(&ab, &ba))
}

/// The pairs `[i, j]` where `ab[i] = j` and `ba[j] = i`: mutual best matches.
pub(crate) fn mutual(ab: &[Option<u32>], ba: &[Option<u32>]) -> Vec<[u32; 2]> {
    ab.iter()
        .enumerate()
        .filter_map(|(i, j)| {
            let j = (*j)?;
            (ba.get(j as usize).copied().flatten() == Some(i as u32)).then_some([i as u32, j])
        })
        .collect()
}

fn best_passing_ratio(matches: &Vector<Vector<DMatch>>, ratio: f32, train_len: usize) -> Vec<Option<u32>> {
    matches
        .iter()
        .map(|m| {
            let first = m.get(0).ok()?;
            let passes = match m.get(1) {
                Ok(second) => first.distance < ratio * second.distance,
                Err(_) => true,
            };
            (passes && (first.train_idx as usize) < train_len).then_some(first.train_idx as u32)
        })
        .collect()
}

/// Mutual nearest neighbours passing the ratio test in both directions.
pub fn mutual_matches(a: &Mat, b: &Mat, options: &MatchOptions) -> SfmResult<Vec<[u32; 2]>> {
    if a.rows() < 2 || b.rows() < 2 {
        return Ok(Vec::new());
    }
    let (mut index_a, mut index_b) = (DescriptorIndex::build(a)?, DescriptorIndex::build(b)?);
    mutual_matches_indexed((a, &mut index_a), (b, &mut index_b), options)
}

fn points(xy: &[[f32; 2]], matches: &[[u32; 2]], side: usize) -> Vector<Point2f> {
    matches
        .iter()
        .map(|m| {
            let p = xy[m[side] as usize];
            Point2f::new(p[0], p[1])
        })
        .collect()
}

fn mask_indices(mask: &Mat) -> SfmResult<Vec<usize>> {
    let bytes = mask.data_bytes().map_err(SfmError::cv("reading an inlier mask"))?;
    Ok(bytes.iter().enumerate().filter(|(_, v)| **v != 0).map(|(i, _)| i).collect())
}

/// Verifies `matches` between keypoints `xy_a` and `xy_b` with a fundamental matrix and a
/// homography (both USAC MAGSAC++). Degenerate pairs keep the homography's inliers.
pub fn verify(xy_a: &[[f32; 2]], xy_b: &[[f32; 2]], matches: &[[u32; 2]], options: &MatchOptions) -> SfmResult<TwoView> {
    if matches.len() < options.min_inliers.max(8) {
        return Ok(TwoView::default());
    }
    let (pa, pb) = (points(xy_a, matches, 0), points(xy_b, matches, 1));
    let mut f_mask = Mat::default();
    let f = calib3d::find_fundamental_mat(&pa, &pb, calib3d::USAC_MAGSAC, options.max_sigma_px, options.confidence, 10_000, &mut f_mask)
        .map_err(SfmError::cv("fundamental matrix"))?;
    let mut h_mask = Mat::default();
    let h = calib3d::find_homography_ext(&pa, &pb, calib3d::USAC_MAGSAC, options.max_sigma_px, &mut h_mask, 10_000, options.confidence)
        .map_err(SfmError::cv("homography"))?;
    let f_inliers = if f.rows() == 3 && !f_mask.empty() { mask_indices(&f_mask)? } else { Vec::new() };
    let h_inliers = if h.rows() == 3 && !h_mask.empty() { mask_indices(&h_mask)? } else { Vec::new() };
    let mut out =
        TwoView { inliers: Vec::new(), fundamental_inliers: f_inliers.len(), homography_inliers: h_inliers.len(), fundamental: None };
    if f.rows() == 3 && f.cols() == 3 {
        let mut m = [0.0; 9];
        for (i, v) in m.iter_mut().enumerate() {
            *v = *f.at_2d::<f64>((i / 3) as i32, (i % 3) as i32).map_err(SfmError::cv("fundamental matrix"))?;
        }
        out.fundamental = Some(m);
    }
    let keep = if out.is_degenerate(options) { &h_inliers } else { &f_inliers };
    if keep.len() >= options.min_inliers {
        out.inliers = keep.iter().map(|&i| matches[i]).collect();
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` descriptors of 128 floats from a fixed generator, one row each.
    fn descriptors(n: usize, seed: u32, noise: f32) -> Vec<Vec<f32>> {
        let mut state = seed;
        let mut next = move || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        (0..n).map(|_| (0..128).map(|_| next() * (1.0 - noise)).collect()).collect()
    }

    fn mat(rows: &[Vec<f32>]) -> Mat {
        Mat::from_slice_2d(rows).expect("descriptor matrix")
    }

    #[test]
    fn exact_and_indexed_matching_find_the_same_true_neighbours() {
        let train = descriptors(300, 7, 0.0);
        // Queries: the training rows in reverse order, slightly perturbed.
        let query: Vec<Vec<f32>> =
            train.iter().rev().enumerate().map(|(i, row)| row.iter().map(|v| v + 0.002 * ((i % 5) as f32)).collect()).collect();
        let mut index = DescriptorIndex::build(&mat(&train)).expect("index");
        let truth: Vec<Option<u32>> = (0..300).map(|i| Some(299 - i as u32)).collect();
        let exact = index.nearest_passing_ratio(&mat(&query), 0.8, usize::MAX).expect("exact");
        assert_eq!(exact, truth, "exact matching missed a true neighbour");
        let indexed = index.nearest_passing_ratio(&mat(&query), 0.8, 0).expect("indexed");
        let found = indexed.iter().zip(&truth).filter(|(a, b)| a == b).count();
        assert!(found >= 290, "FLANN found {found} of 300 well-separated neighbours");
    }
}
