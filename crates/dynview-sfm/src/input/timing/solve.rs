//! The pairs' offsets solved together: each pair of cameras measured one offset between their
//! clocks; the offsets per camera are the weighted least-squares solution with the first camera
//! fixed, dropping the pair that disagrees most while any disagrees by more than a tolerance and
//! every camera stays reached.

use serde::{Deserialize, Serialize};

/// What one pair of cameras measured: `offset_s` = (second camera's video time) - (first's) of
/// one moment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairOffset {
    /// The pair, indices into the cameras.
    pub cameras: [usize; 2],
    /// The offset (s).
    pub offset_s: f64,
    /// Matches at the best offset, summed over the sampled frames.
    pub matches: usize,
    /// 1 - (the best count away from the winner) / (the winner's count).
    pub confidence: f64,
}

/// Per camera, the smallest camera index it is connected to by `pairs`.
pub(crate) fn groups(n: usize, pairs: &[PairOffset]) -> Vec<usize> {
    let mut group: Vec<usize> = (0..n).collect();
    let mut changed = true;
    while changed {
        changed = false;
        for p in pairs {
            let [a, b] = p.cameras;
            let low = group[a].min(group[b]);
            if group[a] != low || group[b] != low {
                group[a] = low;
                group[b] = low;
                changed = true;
            }
        }
    }
    group
}

/// Offsets per camera (camera 0 at 0) from the pairs by weighted least squares, dropping the
/// pair that disagrees most while any disagrees by more than `tolerance_s` and the cameras stay
/// connected; per camera a confidence. `Err(camera)` names a camera no pair reaches.
pub(crate) fn solve_offsets(n: usize, pairs: &[PairOffset], tolerance_s: f64) -> Result<(Vec<f64>, Vec<f64>), usize> {
    let mut used: Vec<&PairOffset> = pairs.iter().filter(|p| p.confidence > 0.0).collect();
    loop {
        let offsets = least_squares(n, &used)?;
        let worst = used
            .iter()
            .enumerate()
            .map(|(k, p)| (k, (offsets[p.cameras[1]] - offsets[p.cameras[0]] - p.offset_s).abs()))
            .max_by(|x, y| x.1.total_cmp(&y.1));
        match worst {
            Some((k, residual)) if residual > tolerance_s => {
                let mut fewer = used.clone();
                fewer.remove(k);
                if least_squares(n, &fewer).is_err() {
                    return Ok((offsets.clone(), confidences(n, &used, &offsets, tolerance_s)));
                }
                used = fewer;
            }
            _ => return Ok((offsets.clone(), confidences(n, &used, &offsets, tolerance_s))),
        }
    }
}

fn confidences(n: usize, used: &[&PairOffset], offsets: &[f64], tolerance_s: f64) -> Vec<f64> {
    (0..n)
        .map(|c| {
            let mine: Vec<f64> = used
                .iter()
                .filter(|p| p.cameras.contains(&c))
                .map(|p| {
                    let residual = (offsets[p.cameras[1]] - offsets[p.cameras[0]] - p.offset_s).abs();
                    if residual > tolerance_s { 0.0 } else { p.confidence }
                })
                .collect();
            mine.iter().copied().fold(0.0, f64::max)
        })
        .collect()
}

/// Weighted least squares of `o_b - o_a = offset` with `o_0 = 0`; `Err(camera)` when a camera
/// is not connected to camera 0.
fn least_squares(n: usize, pairs: &[&PairOffset]) -> Result<Vec<f64>, usize> {
    // Connectivity first: a camera no chain of pairs reaches has no offset.
    let owned: Vec<PairOffset> = pairs.iter().map(|p| (*p).clone()).collect();
    if let Some(missing) = groups(n, &owned).iter().position(|g| *g != 0) {
        return Err(missing);
    }
    if n == 1 {
        return Ok(vec![0.0]);
    }
    let m = n - 1;
    let mut normal = nalgebra::DMatrix::<f64>::zeros(m, m);
    let mut rhs = nalgebra::DVector::<f64>::zeros(m);
    for p in pairs {
        let w = p.confidence.max(1e-3) * p.matches as f64;
        let [a, b] = p.cameras;
        // Row: +1 at b, -1 at a (camera 0 fixed).
        let coefficient = |c: usize| -> Option<(usize, f64)> { if c == 0 { None } else { Some((c - 1, if c == b { 1.0 } else { -1.0 })) } };
        let entries: Vec<(usize, f64)> = [coefficient(a), coefficient(b)].into_iter().flatten().collect();
        for &(r, x) in &entries {
            rhs[r] += w * x * p.offset_s;
            for &(c, y) in &entries {
                normal[(r, c)] += w * x * y;
            }
        }
    }
    let solution = normal.lu().solve(&rhs).ok_or(0usize)?;
    Ok(std::iter::once(0.0).chain(solution.iter().copied()).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(a: usize, b: usize, offset_s: f64) -> PairOffset {
        PairOffset { cameras: [a, b], offset_s, matches: 40, confidence: 0.8 }
    }

    #[test]
    fn pairs_are_solved_together_and_a_wrong_pair_is_dropped() {
        // Truth: 0, 0.5, -0.3, 1.0; the pair (1, 3) is wrong by a second.
        let pairs = [pair(0, 1, 0.5), pair(1, 2, -0.8), pair(0, 2, -0.3), pair(2, 3, 1.3), pair(1, 3, 1.5), pair(0, 3, 1.0)];
        let (offsets, confidence) = solve_offsets(4, &pairs, 1.0 / 60.0).expect("solved");
        for (found, truth) in offsets.iter().zip([0.0, 0.5, -0.3, 1.0]) {
            assert!((found - truth).abs() < 1e-9, "{offsets:?}");
        }
        assert!(confidence.iter().all(|c| *c > 0.5), "{confidence:?}");
    }

    #[test]
    fn a_camera_no_pair_reaches_is_named() {
        let pairs = [pair(0, 1, 0.5), pair(2, 3, 0.1)];
        assert_eq!(solve_offsets(4, &pairs, 0.02).unwrap_err(), 2);
    }
}
