//! The surround test of the sparse consistency filter: a projected sample is hidden when nearer
//! samples lie on every side of it, within a radius set by how sparse the nearer surface is
//! rather than by the cloud's mean spacing.
//!
//! A dense static cloud behind a sparse moving object projects many samples into the gaps
//! between the object's samples; the window of [`super::sparse::SplatMaps::drop_inconsistent`]'s
//! occlusion pass, half the mean spacing, is a pixel or two there, too small to reach across
//! those gaps, so the background shows through the object. A sample with a nearer one in each
//! of its four quadrants lies inside the nearer surface's outline; one beside the outline of a
//! convex nearer surface always has a whole quadrant free of it (any half-plane through a point
//! holds one closed quadrant), so silhouettes are kept. The test never removes a sample of a
//! smooth surface for its own slope: its nearer samples lie on one side.

use crate::par;

/// The smallest value of `values` (`width` x `height`, row-major; `f32::INFINITY` where there is
/// no sample) in each of the four closed quadrant windows of every pixel, `radius` pixels on a
/// side: up-left, up-right, down-left, down-right (up is the row above). Each window holds the
/// pixel itself, the `radius` pixels beside it along its row and column and the block between.
pub fn quadrant_minima(values: &[f32], width: usize, height: usize, radius: usize) -> [Vec<f32>; 4] {
    debug_assert_eq!(values.len(), width * height);
    let left = row_minima(values, width, radius, Side::Before);
    let right = row_minima(values, width, radius, Side::After);
    [
        column_minima(&left, width, height, radius, Side::Before),
        column_minima(&right, width, height, radius, Side::Before),
        column_minima(&left, width, height, radius, Side::After),
        column_minima(&right, width, height, radius, Side::After),
    ]
}

/// Which side of a pixel a one-sided window reaches.
#[derive(Clone, Copy)]
enum Side {
    /// Lower indices: left in a row, up in a column.
    Before,
    /// Higher indices.
    After,
}

/// The one-sided window range `[i - radius, i]` or `[i, i + radius]` inside `0..n`.
fn window(i: usize, n: usize, radius: usize, side: Side) -> std::ops::RangeInclusive<usize> {
    match side {
        Side::Before => i.saturating_sub(radius)..=i,
        Side::After => i..=(i + radius).min(n - 1),
    }
}

/// Per pixel, the minimum over a one-sided window of its row.
fn row_minima(values: &[f32], width: usize, radius: usize, side: Side) -> Vec<f32> {
    let mut out = vec![f32::INFINITY; values.len()];
    par::for_each_row_mut(&mut out, width, |y, row| {
        let source = &values[y * width..(y + 1) * width];
        for (x, v) in row.iter_mut().enumerate() {
            *v = source[window(x, width, radius, side)].iter().copied().fold(f32::INFINITY, f32::min);
        }
    });
    out
}

/// Per pixel, the minimum over a one-sided window of its column.
fn column_minima(values: &[f32], width: usize, height: usize, radius: usize, side: Side) -> Vec<f32> {
    let mut out = vec![f32::INFINITY; values.len()];
    par::for_each_row_mut(&mut out, width, |y, row| {
        for yy in window(y, height, radius, side) {
            for (v, &s) in row.iter_mut().zip(&values[yy * width..(yy + 1) * width]) {
                *v = v.min(s);
            }
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quadrant minima by brute force over each window.
    fn brute(values: &[f32], w: usize, h: usize, r: usize) -> [Vec<f32>; 4] {
        let quadrant = |q: usize| {
            (0..w * h)
                .map(|i| {
                    let (x, y) = (i % w, i / w);
                    let xs = if q.is_multiple_of(2) { x.saturating_sub(r)..=x } else { x..=(x + r).min(w - 1) };
                    let ys = if q < 2 { y.saturating_sub(r)..=y } else { y..=(y + r).min(h - 1) };
                    ys.flat_map(|yy| xs.clone().map(move |xx| values[yy * w + xx])).fold(f32::INFINITY, f32::min)
                })
                .collect()
        };
        [quadrant(0), quadrant(1), quadrant(2), quadrant(3)]
    }

    #[test]
    fn quadrant_minima_match_a_search_of_each_window() {
        let (w, h) = (13, 9);
        let values: Vec<f32> = (0..w * h).map(|i| if (i * 7) % 5 == 0 { ((i * 31) % 17) as f32 } else { f32::INFINITY }).collect();
        for r in [0, 1, 3, 20] {
            assert_eq!(quadrant_minima(&values, w, h, r), brute(&values, w, h, r), "radius {r}");
        }
    }
}
