//! A pair's lag as a line along the recording, fitted robustly to the lags of its windows.

/// Track b's time minus track a's time for the same sound, as a line in track a's time:
/// `lag(t) = lag_s + slope * (t - time_a_s)`; `1 + slope` is the pair's rate ratio.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct LagLine {
    /// The time in track a (s) the line is centred on.
    pub time_a_s: f64,
    /// The lag at `time_a_s` (s).
    pub lag_s: f64,
    /// Seconds of lag gained per second of track a.
    pub slope: f64,
}

impl LagLine {
    /// The lag (s) at time `time_a_s` of track a.
    pub(super) fn lag_at(&self, time_a_s: f64) -> f64 {
        self.lag_s + self.slope * (time_a_s - self.time_a_s)
    }
}

/// A line fitted to some of the points.
#[derive(Clone, Debug)]
pub(super) struct LineFit {
    /// The least-squares line through the inliers (centred on their mean time; slope 0 from a
    /// single inlier).
    pub line: LagLine,
    /// For each point, whether it is within the tolerance of the line.
    pub inliers: Vec<bool>,
    /// The inliers' count.
    pub inlier_count: usize,
}

/// The line with most points `(time, lag)` within `tolerance_s` of it, among lines through two
/// points with `|slope| <= max_slope` and flat lines through one point, refitted by least
/// squares to its inliers until they stop changing. `None` without points.
pub(super) fn robust_line(points: &[(f64, f64)], tolerance_s: f64, max_slope: f64) -> Option<LineFit> {
    let mut best: Option<(usize, f64, LagLine)> = None;
    let mut consider = |line: LagLine| {
        let (count, spread) = score(points, &line, tolerance_s);
        if best.as_ref().is_none_or(|(c, s, _)| count > *c || (count == *c && spread < *s)) {
            best = Some((count, spread, line));
        }
    };
    for (i, &(t_i, lag_i)) in points.iter().enumerate() {
        consider(LagLine { time_a_s: t_i, lag_s: lag_i, slope: 0.0 });
        for &(t_j, lag_j) in &points[i + 1..] {
            let slope = (lag_j - lag_i) / (t_j - t_i);
            if slope.is_finite() && slope.abs() <= max_slope {
                consider(LagLine { time_a_s: t_i, lag_s: lag_i, slope });
            }
        }
    }
    let (_, _, mut line) = best?;
    let mut inliers = inlier_mask(points, &line, tolerance_s);
    for _ in 0..points.len() {
        let Some(refit) = least_squares(points, &inliers, max_slope) else { break };
        let refit_inliers = inlier_mask(points, &refit, tolerance_s);
        if refit_inliers.iter().filter(|&&x| x).count() < inliers.iter().filter(|&&x| x).count() {
            break;
        }
        line = refit;
        if refit_inliers == inliers {
            break;
        }
        inliers = refit_inliers;
    }
    let inlier_count = inliers.iter().filter(|&&x| x).count();
    Some(LineFit { line, inliers, inlier_count })
}

fn score(points: &[(f64, f64)], line: &LagLine, tolerance_s: f64) -> (usize, f64) {
    points.iter().map(|&(t, lag)| (lag - line.lag_at(t)).abs()).filter(|r| *r <= tolerance_s).fold((0, 0.0), |(n, s), r| (n + 1, s + r * r))
}

fn inlier_mask(points: &[(f64, f64)], line: &LagLine, tolerance_s: f64) -> Vec<bool> {
    points.iter().map(|&(t, lag)| (lag - line.lag_at(t)).abs() <= tolerance_s).collect()
}

/// Least-squares line through the chosen points, its slope clamped to ±`max_slope`; flat
/// through their mean when their times do not spread.
fn least_squares(points: &[(f64, f64)], chosen: &[bool], max_slope: f64) -> Option<LagLine> {
    let selected = || points.iter().zip(chosen).filter(|(_, c)| **c).map(|(p, _)| *p);
    let count = selected().count();
    if count == 0 {
        return None;
    }
    let mean_t = selected().map(|p| p.0).sum::<f64>() / count as f64;
    let mean_lag = selected().map(|p| p.1).sum::<f64>() / count as f64;
    let var_t: f64 = selected().map(|p| (p.0 - mean_t) * (p.0 - mean_t)).sum();
    let cov: f64 = selected().map(|p| (p.0 - mean_t) * (p.1 - mean_lag)).sum();
    let slope = if count >= 2 && var_t > 1e-12 { (cov / var_t).clamp(-max_slope, max_slope) } else { 0.0 };
    Some(LagLine { time_a_s: mean_t, lag_s: mean_lag, slope })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robust_line_ignores_an_outlier_and_recovers_the_slope() {
        let truth = LagLine { time_a_s: 0.0, lag_s: 1.5, slope: 3e-4 };
        let mut points: Vec<(f64, f64)> = (0..8).map(|k| (5.0 + 10.0 * k as f64, truth.lag_at(5.0 + 10.0 * k as f64))).collect();
        points[3].1 += 0.02;
        let fit = robust_line(&points, 0.001, 1e-3).expect("points given");
        assert_eq!(fit.inlier_count, 7);
        assert!(!fit.inliers[3]);
        assert!((fit.line.slope - truth.slope).abs() < 1e-12);
        assert!((fit.line.lag_at(40.0) - truth.lag_at(40.0)).abs() < 1e-12);
    }

    #[test]
    fn one_point_gives_a_flat_line_and_none_gives_none() {
        let fit = robust_line(&[(3.0, 0.25)], 0.001, 1e-3).expect("a point");
        assert_eq!(fit.line, LagLine { time_a_s: 3.0, lag_s: 0.25, slope: 0.0 });
        assert!(robust_line(&[], 0.001, 1e-3).is_none());
    }
}
