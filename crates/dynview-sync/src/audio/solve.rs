//! The joint solve: every camera's clock from the pairs' offsets and rate ratios by weighted
//! least squares, robust to a pair that found the wrong peak; cameras no reliable pair reaches
//! are hung on their best pair with that pair's (low) confidence.

use super::AudioOptions;
use super::pair::PairMeasurement;
use crate::clock::Clock;
use crate::error::{SyncError, SyncResult};

/// Weight of the prior "rate 1" on every camera's log-rate, against pair weights of about 1: it
/// only decides what no pair measures (the rate of a camera whose pairs are all short). The
/// starts need none: a group is connected by its pairs.
const RATE_PRIOR_WEIGHT: f64 = 1e-9;

/// Every camera's clock and how well the pairs support it.
pub(super) struct Solution {
    /// One clock per camera, the first synchronized.
    pub clocks: Vec<Clock>,
    /// One confidence per camera, 0 to 1.
    pub confidence: Vec<f64>,
    /// Per camera, the used pairs with it.
    pub pairs_used: Vec<usize>,
    /// Per pair, whether the solve used it.
    pub used: Vec<bool>,
    /// Per pair, its disagreement with the clocks (s), see [`super::PairOffset::residual_s`].
    pub residual_s: Vec<f64>,
}

/// Solves the clocks of `names.len()` cameras from `pairs`.
pub(super) fn solve_clocks(names: &[String], pairs: &[PairMeasurement], options: &AudioOptions) -> SyncResult<Solution> {
    let n = names.len();
    let mut used: Vec<bool> = pairs.iter().map(|p| p.confidence > 0.0 && p.confidence >= options.min_confidence).collect();
    let (mut groups, mut clocks) = loop {
        let groups = components(n, pairs, &used);
        let clocks = solve_groups(n, &groups, pairs, &used)?;
        let group_count = groups.iter().max().map_or(0, |g| g + 1);
        let mut over: Vec<(usize, f64)> = (0..pairs.len())
            .filter(|&p| used[p])
            .map(|p| (p, residual_s(&pairs[p], &clocks)))
            .filter(|(_, r)| *r > options.outlier_threshold_s)
            .collect();
        over.sort_by(|x, y| y.1.total_cmp(&x.1));
        let droppable = over.iter().map(|(p, _)| *p).find(|&p| {
            used[p] = false;
            let keeps = components(n, pairs, &used).iter().max().map_or(0, |g| g + 1) == group_count;
            used[p] = true;
            keeps
        });
        match droppable {
            Some(p) => used[p] = false,
            None => break (groups, clocks),
        }
    };

    // Hang the groups no reliable pair joins to the first camera's on their best pair.
    let mut cap = vec![1.0f64; n];
    let mut joined: Vec<bool> = groups.iter().map(|&g| g == groups[0]).collect();
    while joined.iter().any(|j| !j) {
        let link = (0..pairs.len())
            .filter(|&p| joined[pairs[p].a] != joined[pairs[p].b])
            .max_by(|&p, &q| pairs[p].confidence.total_cmp(&pairs[q].confidence));
        let Some(link) = link else {
            let missing: Vec<&str> = (0..n).filter(|&c| !joined[c]).map(|c| names[c].as_str()).collect();
            return Err(SyncError::NoOverlap(format!("no pair of sound tracks ties camera(s) {} to the others", missing.join(", "))));
        };
        let pair = &pairs[link];
        let (known, unknown) = if joined[pair.a] { (pair.a, pair.b) } else { (pair.b, pair.a) };
        let target = hang(pair, known, &clocks[known]);
        let local = clocks[unknown];
        let group = groups[unknown];
        // The group's clocks map its own first camera's time u to theirs; u = shift + scale * tau.
        let scale = target.rate / local.rate;
        let shift = (target.start_s - local.start_s) / local.rate;
        let link_cap = cap[known].min(pair.confidence);
        let members: Vec<usize> = (0..n).filter(|&c| groups[c] == group).collect();
        for c in members {
            let own = clocks[c];
            clocks[c] = Clock { start_s: own.start_s + own.rate * shift, rate: own.rate * scale };
            cap[c] = link_cap;
            joined[c] = true;
            groups[c] = groups[0];
        }
    }

    let residual: Vec<f64> = pairs.iter().map(|p| residual_s(p, &clocks)).collect();
    let mut confidence = vec![0.0f64; n];
    let mut pairs_used = vec![0usize; n];
    for c in 0..n {
        let mine = || (0..pairs.len()).filter(move |&p| pairs[p].a == c || pairs[p].b == c);
        let agreement = |p: usize| (-0.5 * (residual[p] / options.outlier_threshold_s).powi(2)).exp();
        pairs_used[c] = mine().filter(|&p| used[p]).count();
        let own = if pairs_used[c] > 0 {
            mine().filter(|&p| used[p]).map(|p| pairs[p].confidence * agreement(p)).fold(0.0, f64::max)
        } else {
            mine().map(|p| pairs[p].confidence).fold(0.0, f64::max)
        };
        confidence[c] = own.min(cap[c]);
    }
    Ok(Solution { clocks, confidence, pairs_used, used, residual_s: residual })
}

/// The clock of camera `unknown` that makes `pair` hold exactly, given camera `known`'s clock.
fn hang(pair: &PairMeasurement, known: usize, clock: &Clock) -> Clock {
    if pair.a == known {
        let rate = clock.rate * pair.rate_ratio;
        let s0 = (pair.time_a_s - clock.start_s) / clock.rate;
        Clock { start_s: pair.time_a_s + pair.offset_s - rate * s0, rate }
    } else {
        let rate = clock.rate / pair.rate_ratio;
        let s0 = (pair.time_a_s + pair.offset_s - clock.start_s) / clock.rate;
        Clock { start_s: pair.time_a_s - rate * s0, rate }
    }
}

/// How far `clocks` disagree with `pair` (s): the offset at the pair's time, or the rate ratio's
/// difference times half the span measured where that is more.
fn residual_s(pair: &PairMeasurement, clocks: &[Clock]) -> f64 {
    let (clock_a, clock_b) = (clocks[pair.a], clocks[pair.b]);
    let ratio = clock_b.rate / clock_a.rate;
    let predicted_b_s = clock_b.video_time_s(clock_a.timeline_time_s(pair.time_a_s));
    let offset_error = predicted_b_s - (pair.time_a_s + pair.offset_s);
    let rate_error = if pair.rate_measured { (ratio - pair.rate_ratio) * 0.5 * pair.span_s } else { 0.0 };
    offset_error.abs().max(rate_error.abs())
}

/// A group number per camera: cameras joined by used pairs share it; camera 0's group is 0.
fn components(n: usize, pairs: &[PairMeasurement], used: &[bool]) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut c: usize) -> usize {
        while parent[c] != c {
            parent[c] = parent[parent[c]];
            c = parent[c];
        }
        c
    }
    for (pair, _) in pairs.iter().zip(used).filter(|(_, u)| **u) {
        let (ra, rb) = (root(&mut parent, pair.a), root(&mut parent, pair.b));
        parent[ra.max(rb)] = ra.min(rb);
    }
    let roots: Vec<usize> = (0..n).map(|c| root(&mut parent, c)).collect();
    let mut numbers: Vec<usize> = Vec::new();
    roots.iter().map(|r| numbers.iter().position(|x| x == r).unwrap_or_else(|| (numbers.push(*r), numbers.len() - 1).1)).collect()
}

/// Each group's clocks against its own first camera, by weighted least squares: the log-rates
/// from the pairs that measured a rate ratio, then the starts from every used pair.
fn solve_groups(n: usize, groups: &[usize], pairs: &[PairMeasurement], used: &[bool]) -> SyncResult<Vec<Clock>> {
    let mut clocks = vec![Clock::SYNCHRONIZED; n];
    let group_count = groups.iter().max().map_or(0, |g| g + 1);
    for group in 0..group_count {
        let members: Vec<usize> = (0..n).filter(|&c| groups[c] == group).collect();
        // The group's first camera is fixed; unknown i is members[i + 1].
        let unknown = |c: usize| members.iter().position(|&m| m == c).and_then(|i| i.checked_sub(1));
        let mine: Vec<&PairMeasurement> = pairs.iter().zip(used).filter(|(p, u)| **u && groups[p.a] == group).map(|(p, _)| p).collect();
        let m = members.len() - 1;
        if m == 0 {
            continue;
        }
        let mut rates = NormalEquations::new(m, RATE_PRIOR_WEIGHT);
        for pair in mine.iter().filter(|p| p.rate_measured) {
            rates.add(&[(unknown(pair.b), 1.0), (unknown(pair.a), -1.0)], pair.rate_ratio.ln(), pair.confidence);
        }
        let log_rates = rates.solve()?;
        for (i, &c) in members.iter().enumerate().skip(1) {
            clocks[c].rate = log_rates[i - 1].exp();
        }
        let mut starts = NormalEquations::new(m, 0.0);
        for pair in &mine {
            // start_b - ratio * start_a = t + offset - ratio * t, at t = the pair's time in a.
            let ratio = clocks[pair.b].rate / clocks[pair.a].rate;
            let value = pair.time_a_s + pair.offset_s - ratio * pair.time_a_s;
            starts.add(&[(unknown(pair.b), 1.0), (unknown(pair.a), -ratio)], value, pair.confidence);
        }
        let start_s = starts.solve()?;
        for (i, &c) in members.iter().enumerate().skip(1) {
            clocks[c].start_s = start_s[i - 1];
        }
    }
    Ok(clocks)
}

/// The normal equations of a small weighted least-squares problem with a prior of 0 on every
/// unknown.
struct NormalEquations {
    size: usize,
    matrix: Vec<f64>,
    rhs: Vec<f64>,
}

impl NormalEquations {
    fn new(size: usize, prior_weight: f64) -> Self {
        let mut matrix = vec![0.0; size * size];
        for i in 0..size {
            matrix[i * size + i] = prior_weight;
        }
        Self { size, matrix, rhs: vec![0.0; size] }
    }

    /// Adds the equation `sum coefficient * x[unknown] = value` (terms with no unknown are
    /// fixed at 0) with `weight`.
    fn add(&mut self, terms: &[(Option<usize>, f64)], value: f64, weight: f64) {
        for &(i, ci) in terms {
            let Some(i) = i else { continue };
            self.rhs[i] += weight * ci * value;
            for &(j, cj) in terms {
                if let Some(j) = j {
                    self.matrix[i * self.size + j] += weight * ci * cj;
                }
            }
        }
    }

    /// The solution by Gaussian elimination with partial pivoting.
    fn solve(mut self) -> SyncResult<Vec<f64>> {
        let n = self.size;
        for col in 0..n {
            let pivot = (col..n).max_by(|&i, &j| self.matrix[i * n + col].abs().total_cmp(&self.matrix[j * n + col].abs())).unwrap_or(col);
            let pivot_value = self.matrix[pivot * n + col].abs();
            if pivot_value.is_nan() || pivot_value == 0.0 {
                return Err(SyncError::Failed("the sound pairs' equations are singular".into()));
            }
            if pivot != col {
                for k in 0..n {
                    self.matrix.swap(pivot * n + k, col * n + k);
                }
                self.rhs.swap(pivot, col);
            }
            for row in col + 1..n {
                let factor = self.matrix[row * n + col] / self.matrix[col * n + col];
                for k in col..n {
                    self.matrix[row * n + k] -= factor * self.matrix[col * n + k];
                }
                self.rhs[row] -= factor * self.rhs[col];
            }
        }
        let mut x = vec![0.0; n];
        for row in (0..n).rev() {
            let tail: f64 = (row + 1..n).map(|k| self.matrix[row * n + k] * x[k]).sum();
            x[row] = (self.rhs[row] - tail) / self.matrix[row * n + row];
        }
        if x.iter().all(|v| v.is_finite()) { Ok(x) } else { Err(SyncError::Failed("the sound pairs' solution is not finite".into())) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn truth() -> Vec<Clock> {
        vec![
            Clock::SYNCHRONIZED,
            Clock { start_s: 3.2, rate: 1.0 },
            Clock { start_s: -7.6, rate: 1.0 + 3.3e-4 },
            Clock { start_s: 12.1, rate: 1.0 - 1e-4 },
        ]
    }

    /// The exact measurement of the pair `(a, b)` of `clocks` at time 30 s of a.
    fn measure(clocks: &[Clock], a: usize, b: usize, confidence: f64) -> PairMeasurement {
        let time_a_s = 30.0;
        let time_b_s = clocks[b].video_time_s(clocks[a].timeline_time_s(time_a_s));
        PairMeasurement {
            a,
            b,
            coarse_offset_s: time_b_s - time_a_s,
            coarse_peak_ratio: 50.0,
            time_a_s,
            offset_s: time_b_s - time_a_s,
            rate_ratio: clocks[b].rate / clocks[a].rate,
            rate_measured: true,
            span_s: 60.0,
            windows_used: 6,
            windows_total: 6,
            confidence,
        }
    }

    fn all_pairs(clocks: &[Clock], confidence: impl Fn(usize, usize) -> f64) -> Vec<PairMeasurement> {
        (0..clocks.len())
            .flat_map(|a| (a + 1..clocks.len()).map(move |b| (a, b)))
            .map(|(a, b)| measure(clocks, a, b, confidence(a, b)))
            .collect()
    }

    fn names() -> Vec<String> {
        (0..4).map(|c| format!("camera{c}")).collect()
    }

    fn assert_clocks_near(found: &[Clock], expected: &[Clock], tolerance_s: f64) {
        for (c, (f, e)) in found.iter().zip(expected).enumerate() {
            assert!((f.start_s - e.start_s).abs() < tolerance_s, "camera {c}: start {} vs {}", f.start_s, e.start_s);
            assert!((f.rate - e.rate).abs() < 1e-9, "camera {c}: rate {} vs {}", f.rate, e.rate);
        }
    }

    #[test]
    fn a_wrong_pair_is_dropped_and_the_rest_solve_exactly() {
        let clocks = truth();
        let mut pairs = all_pairs(&clocks, |_, _| 0.9);
        let wrong = pairs.iter().position(|p| (p.a, p.b) == (1, 2)).expect("pair 1-2");
        pairs[wrong].offset_s += 0.05;
        let solution = solve_clocks(&names(), &pairs, &AudioOptions::default()).expect("solvable");
        assert_clocks_near(&solution.clocks, &clocks, 1e-9);
        assert!(!solution.used[wrong]);
        assert!((solution.residual_s[wrong] - 0.05).abs() < 1e-9);
        assert_eq!(solution.pairs_used, vec![3, 2, 2, 3]);
        assert!(solution.confidence.iter().all(|&c| c > 0.89), "{:?}", solution.confidence);
    }

    #[test]
    fn a_camera_without_reliable_pairs_hangs_on_its_best_with_its_confidence() {
        let clocks = truth();
        let mut pairs = all_pairs(&clocks, |_, b| if b == 3 { 0.1 } else { 0.9 });
        let best = pairs.iter().position(|p| (p.a, p.b) == (1, 3)).expect("pair 1-3");
        pairs[best].confidence = 0.2;
        pairs[best].offset_s += 0.01;
        let solution = solve_clocks(&names(), &pairs, &AudioOptions::default()).expect("solvable");
        assert_clocks_near(&solution.clocks[..3], &clocks[..3], 1e-9);
        assert!((solution.clocks[3].start_s - clocks[3].start_s - 0.01).abs() < 1e-6, "{:?}", solution.clocks[3]);
        assert_eq!(solution.pairs_used[3], 0);
        assert!((solution.confidence[3] - 0.2).abs() < 1e-12);
    }

    #[test]
    fn a_first_camera_without_reliable_pairs_lowers_everyones_confidence() {
        let clocks = truth();
        let pairs = all_pairs(&clocks, |a, _| if a == 0 { 0.1 } else { 0.9 });
        let solution = solve_clocks(&names(), &pairs, &AudioOptions::default()).expect("solvable");
        assert_clocks_near(&solution.clocks, &clocks, 1e-9);
        assert!(solution.confidence.iter().all(|&c| c <= 0.1 + 1e-12), "{:?}", solution.confidence);
    }
}
