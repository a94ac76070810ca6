//! Data parallelism in one place: rayon with the `parallel` feature, plain loops otherwise
//! (a browser build runs in a single Web Worker).

/// Maps `f` over `0..n`, in parallel when enabled, keeping the order of results.
pub(crate) fn map_range<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
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

/// How many workers [`map_range`] can keep busy.
pub(crate) fn worker_count() -> usize {
    #[cfg(feature = "parallel")]
    {
        rayon::current_num_threads().max(1)
    }
    #[cfg(not(feature = "parallel"))]
    {
        1
    }
}

/// Splits `0..n` into at most `max_chunks` contiguous ranges of at least `min_len` items.
pub(crate) fn chunk_ranges(n: usize, max_chunks: usize, min_len: usize) -> Vec<std::ops::Range<usize>> {
    let chunks = (n / min_len.max(1)).clamp(1, max_chunks.max(1));
    (0..chunks).map(|chunk| chunk * n / chunks..(chunk + 1) * n / chunks).collect()
}
