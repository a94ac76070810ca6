//! Data parallelism in one place: rayon on native targets with the `parallel` feature, plain
//! loops otherwise (the browser's CPU path runs in a single Web Worker).

/// Calls `f(row_index, row)` for every `width`-long row of `data`, in parallel when enabled.
pub fn for_each_row_mut<T: Send>(data: &mut [T], width: usize, f: impl Fn(usize, &mut [T]) + Sync + Send) {
    if width == 0 {
        return;
    }
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        data.par_chunks_mut(width).enumerate().for_each(|(y, row)| f(y, row));
    }
    #[cfg(not(feature = "parallel"))]
    {
        data.chunks_mut(width).enumerate().for_each(|(y, row)| f(y, row));
    }
}

/// Maps `f` over `0..n`, in parallel when enabled, keeping the order of results.
pub fn map_range<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        (0..n).into_par_iter().map(f).collect()
    }
    #[cfg(not(feature = "parallel"))]
    {
        (0..n).map(f).collect()
    }
}

/// Sums `f(row)` over `0..rows`, in parallel when enabled (f64 accumulation).
pub fn sum_rows(rows: usize, f: impl Fn(usize) -> f64 + Sync + Send) -> f64 {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        (0..rows).into_par_iter().map(f).sum()
    }
    #[cfg(not(feature = "parallel"))]
    {
        (0..rows).map(f).sum()
    }
}
