//! Block-sparse Cholesky factorisation of the reduced camera system.
//!
//! The unknowns come in blocks ("nodes": one per free image, one per camera with free
//! intrinsics). A greedy minimum-degree ordering of the node graph fixes the elimination order
//! and the fill; the factor `L` is stored column by column, each column holding its dense
//! diagonal block followed by its dense off-diagonal blocks (row-major), so assembly, factorisation
//! and solves all work on one flat value array.

use super::ordering::{BlockGraph, minimum_degree_order};

/// The factorisation failed: a pivot was not positive (the matrix is not numerically definite).
#[derive(Debug, Clone, Copy)]
pub(crate) struct NotPositiveDefinite;

/// Elimination order, factor structure and value layout of a block-sparse symmetric matrix.
pub(crate) struct BlockPattern {
    node_size: Vec<usize>,
    node_offset: Vec<usize>,
    dim: usize,
    position_of_node: Vec<usize>,
    /// Block size at each elimination position.
    size_at: Vec<usize>,
    /// Offset of each position's entries in the permuted vector.
    position_offset: Vec<usize>,
    /// For each position `j`, the sorted positions `i > j` with a structural block `L(i, j)`.
    rows: Vec<Vec<usize>>,
    /// Start of each position's column in the values; `column_start[n]` is the value count.
    column_start: Vec<usize>,
    /// For each position `j` and each of its rows, the block's offset from `column_start[j]`.
    row_block_start: Vec<Vec<usize>>,
}

impl BlockPattern {
    /// Orders the nodes by minimum degree and lays out the factor.
    pub(crate) fn new(node_size: Vec<usize>, graph: BlockGraph) -> Self {
        debug_assert_eq!(node_size.len(), graph.node_count);
        let (order, neighbours) = minimum_degree_order(graph);
        let node_count = node_size.len();
        let mut position_of_node = vec![0; node_count];
        for (position, &node) in order.iter().enumerate() {
            position_of_node[node] = position;
        }
        let mut node_offset = Vec::with_capacity(node_count);
        let mut dim = 0;
        for &size in &node_size {
            node_offset.push(dim);
            dim += size;
        }
        let size_at: Vec<usize> = order.iter().map(|&node| node_size[node]).collect();
        let mut position_offset = Vec::with_capacity(node_count);
        let mut running = 0;
        for &size in &size_at {
            position_offset.push(running);
            running += size;
        }
        let mut rows = Vec::with_capacity(node_count);
        let mut column_start = Vec::with_capacity(node_count + 1);
        let mut row_block_start = Vec::with_capacity(node_count);
        let mut value_count = 0;
        for (position, nodes) in neighbours.into_iter().enumerate() {
            let mut column_rows: Vec<usize> = nodes.into_iter().map(|node| position_of_node[node]).collect();
            column_rows.sort_unstable();
            let width = size_at[position];
            column_start.push(value_count);
            let mut offset = width * width;
            let mut starts = Vec::with_capacity(column_rows.len());
            for &row in &column_rows {
                starts.push(offset);
                offset += size_at[row] * width;
            }
            value_count += offset;
            rows.push(column_rows);
            row_block_start.push(starts);
        }
        column_start.push(value_count);
        Self { node_size, node_offset, dim, position_of_node, size_at, position_offset, rows, column_start, row_block_start }
    }

    /// Total number of scalar unknowns.
    pub(crate) fn dim(&self) -> usize {
        self.dim
    }

    /// Length of the value array.
    pub(crate) fn value_count(&self) -> usize {
        self.column_start[self.size_at.len()]
    }

    /// Offset of a node's entries in node-ordered vectors.
    pub(crate) fn node_offset(&self, node: usize) -> usize {
        self.node_offset[node]
    }

    /// Number of scalar unknowns of a node.
    pub(crate) fn node_size(&self, node: usize) -> usize {
        self.node_size[node]
    }

    /// Offset of the stored block `(row_position, column_position)` with `row_position >= column_position`.
    fn block_at(&self, row_position: usize, column_position: usize) -> Option<usize> {
        let start = self.column_start[column_position];
        if row_position == column_position {
            return Some(start);
        }
        let entry = self.rows[column_position].binary_search(&row_position).ok()?;
        Some(start + self.row_block_start[column_position][entry])
    }

    /// Where the block `(a, b)` of the symmetric matrix is stored; `None` when it is
    /// structurally zero.
    pub(crate) fn slot(&self, a: usize, b: usize) -> Option<BlockSlot> {
        let (position_a, position_b) = (self.position_of_node[a], self.position_of_node[b]);
        // Stored as (row, column) with row position >= column position; transposed otherwise.
        if position_a >= position_b {
            Some(BlockSlot { offset: self.block_at(position_a, position_b)?, transposed: false })
        } else {
            Some(BlockSlot { offset: self.block_at(position_b, position_a)?, transposed: true })
        }
    }

    /// Adds `scale * X Y^T` to the block `(a, b)` of the symmetric matrix, `X` being `size(a) x k`
    /// and `Y` `size(b) x k`, both row-major. Diagonal blocks are kept full (both triangles).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn add_product(&self, values: &mut [f64], a: usize, b: usize, x: &[f64], y: &[f64], k: usize, scale: f64) {
        match self.slot(a, b) {
            Some(slot) => add_product_at(values, slot, x, y, k, scale),
            None => debug_assert!(false, "block ({a}, {b}) is not in the pattern"),
        }
    }

    /// Offset in the values of the diagonal entry `local` of `node`.
    pub(crate) fn diagonal_index(&self, node: usize, local: usize) -> usize {
        let size = self.node_size[node];
        self.column_start[self.position_of_node[node]] + local * size + local
    }

    /// Factorises the (assembled, lower) matrix in place: `A = L L^T`.
    pub(crate) fn factor(&self, values: &mut [f64]) -> Result<(), NotPositiveDefinite> {
        for position in 0..self.size_at.len() {
            let width = self.size_at[position];
            let (done, later) = values.split_at_mut(self.column_start[position + 1]);
            let column = &mut done[self.column_start[position]..];
            let (diagonal, off_diagonal) = column.split_at_mut(width * width);
            dense_cholesky_in_place(diagonal, width)?;
            for row_block in off_diagonal.chunks_exact_mut(width) {
                // Each row x of the block solves x L^T = b.
                forward_substitute(diagonal, width, row_block);
            }
            let rows = &self.rows[position];
            let starts = &self.row_block_start[position];
            let later_start = self.column_start[position + 1];
            for (entry_a, &row_a) in rows.iter().enumerate() {
                let size_a = self.size_at[row_a];
                let block_a = &column[starts[entry_a]..starts[entry_a] + size_a * width];
                for (entry_b, &row_b) in rows.iter().enumerate().take(entry_a + 1) {
                    let size_b = self.size_at[row_b];
                    let block_b = &column[starts[entry_b]..starts[entry_b] + size_b * width];
                    let Some(target) = self.block_at(row_a, row_b) else {
                        debug_assert!(false, "fill block ({row_a}, {row_b}) missing");
                        continue;
                    };
                    let target = &mut later[target - later_start..target - later_start + size_a * size_b];
                    for r in 0..size_a {
                        let x = &block_a[r * width..(r + 1) * width];
                        for c in 0..size_b {
                            let y = &block_b[c * width..(c + 1) * width];
                            target[r * size_b + c] -= x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>();
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// Solves `L L^T x = rhs` with the factor from [`BlockPattern::factor`]; vectors in node order.
    pub(crate) fn solve(&self, values: &[f64], rhs: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.dim];
        for (node, &position) in self.position_of_node.iter().enumerate() {
            let size = self.node_size[node];
            y[self.position_offset[position]..][..size].copy_from_slice(&rhs[self.node_offset[node]..][..size]);
        }
        let positions = self.size_at.len();
        for position in 0..positions {
            let width = self.size_at[position];
            let start = self.column_start[position];
            let diagonal = &values[start..start + width * width];
            let offset = self.position_offset[position];
            let mut own = y[offset..offset + width].to_vec();
            forward_substitute(diagonal, width, &mut own);
            y[offset..offset + width].copy_from_slice(&own);
            for (&row, &block_start) in self.rows[position].iter().zip(&self.row_block_start[position]) {
                let size = self.size_at[row];
                let block = &values[start + block_start..start + block_start + size * width];
                let row_offset = self.position_offset[row];
                for r in 0..size {
                    y[row_offset + r] -= block[r * width..(r + 1) * width].iter().zip(&own).map(|(p, q)| p * q).sum::<f64>();
                }
            }
        }
        for position in (0..positions).rev() {
            let width = self.size_at[position];
            let start = self.column_start[position];
            let offset = self.position_offset[position];
            let mut own = y[offset..offset + width].to_vec();
            for (&row, &block_start) in self.rows[position].iter().zip(&self.row_block_start[position]) {
                let size = self.size_at[row];
                let block = &values[start + block_start..start + block_start + size * width];
                let row_offset = self.position_offset[row];
                for r in 0..size {
                    let value = y[row_offset + r];
                    for (entry, &l) in own.iter_mut().zip(&block[r * width..(r + 1) * width]) {
                        *entry -= l * value;
                    }
                }
            }
            backward_substitute(&values[start..start + width * width], width, &mut own);
            y[offset..offset + width].copy_from_slice(&own);
        }
        let mut x = vec![0.0; self.dim];
        for (node, &position) in self.position_of_node.iter().enumerate() {
            let size = self.node_size[node];
            x[self.node_offset[node]..][..size].copy_from_slice(&y[self.position_offset[position]..][..size]);
        }
        x
    }
}

/// Where one block of the symmetric matrix lives in the value array.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BlockSlot {
    /// Offset of the stored block.
    offset: usize,
    /// Whether the stored block is the transpose of the requested one.
    transposed: bool,
}

/// Adds `scale * X Y^T` (`X` rows x k, `Y` columns x k, row-major) to the block at `slot`.
pub(crate) fn add_product_at(values: &mut [f64], slot: BlockSlot, x: &[f64], y: &[f64], k: usize, scale: f64) {
    // The stored block is X Y^T, or Y X^T when transposed; either way rows of the first factor
    // are rows of the stored block.
    let (rows, columns) = if slot.transposed { (y, x) } else { (x, y) };
    let target = &mut values[slot.offset..slot.offset + (rows.len() / k) * (columns.len() / k)];
    match k {
        2 => add_outer::<2>(target, rows, columns, scale),
        3 => add_outer::<3>(target, rows, columns, scale),
        6 => add_outer::<6>(target, rows, columns, scale),
        _ => {
            let width = columns.len() / k;
            for (out_row, x) in target.chunks_exact_mut(width.max(1)).zip(rows.chunks_exact(k)) {
                for (out, y) in out_row.iter_mut().zip(columns.chunks_exact(k)) {
                    *out += scale * x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>();
                }
            }
        }
    }
}

/// `target += scale * rows columns^T` with a compile-time inner dimension.
#[inline(always)]
fn add_outer<const K: usize>(target: &mut [f64], rows: &[f64], columns: &[f64], scale: f64) {
    let width = columns.len() / K;
    if width == 0 {
        return;
    }
    for (out_row, x) in target.chunks_exact_mut(width).zip(rows.chunks_exact(K)) {
        let x: &[f64; K] = x.try_into().unwrap_or(&[0.0; K]);
        for (out, y) in out_row.iter_mut().zip(columns.chunks_exact(K)) {
            let y: &[f64; K] = y.try_into().unwrap_or(&[0.0; K]);
            let mut dot = 0.0;
            for t in 0..K {
                dot += x[t] * y[t];
            }
            *out += scale * dot;
        }
    }
}

/// In-place Cholesky of a dense row-major `n x n` block; only the lower triangle is read and written.
fn dense_cholesky_in_place(block: &mut [f64], n: usize) -> Result<(), NotPositiveDefinite> {
    for c in 0..n {
        let pivot = block[c * n + c] - block[c * n..c * n + c].iter().map(|v| v * v).sum::<f64>();
        if !(pivot > 0.0 && pivot.is_finite()) {
            return Err(NotPositiveDefinite);
        }
        let root = pivot.sqrt();
        block[c * n + c] = root;
        for r in c + 1..n {
            let dot: f64 = (0..c).map(|t| block[r * n + t] * block[c * n + t]).sum();
            block[r * n + c] = (block[r * n + c] - dot) / root;
        }
    }
    Ok(())
}

/// Solves `L z = b` in place (equivalently `z^T L^T = b^T`), `L` lower of a dense row-major block.
fn forward_substitute(lower: &[f64], n: usize, b: &mut [f64]) {
    for c in 0..n {
        let dot: f64 = (0..c).map(|t| lower[c * n + t] * b[t]).sum();
        b[c] = (b[c] - dot) / lower[c * n + c];
    }
}

/// Solves `L^T z = b` in place, `L` lower of a dense row-major block.
fn backward_substitute(lower: &[f64], n: usize, b: &mut [f64]) {
    for c in (0..n).rev() {
        let dot: f64 = (c + 1..n).map(|t| lower[t * n + c] * b[t]).sum();
        b[c] = (b[c] - dot) / lower[c * n + c];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// A deterministic pseudo-random number in [-1, 1).
    fn noise(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    fn check(node_size: Vec<usize>, edges: &[(usize, usize)], seed: u64) {
        let mut seed = seed;
        let node_count = node_size.len();
        let mut graph = BlockGraph::new(node_count);
        for &(a, b) in edges {
            graph.add_edge(a, b);
        }
        let pattern = BlockPattern::new(node_size.clone(), graph);
        let dim = pattern.dim();
        // A = I + sum over edges (a, b) of J^T J with J = [J_a J_b] random: symmetric positive definite.
        let mut dense = DMatrix::<f64>::identity(dim, dim);
        let mut values = vec![0.0; pattern.value_count()];
        for (node, &size) in node_size.iter().enumerate() {
            let identity: Vec<f64> = (0..size * size).map(|i| if i % (size + 1) == 0 { 1.0 } else { 0.0 }).collect();
            pattern.add_product(&mut values, node, node, &identity, &identity, size, 1.0);
        }
        for &(a, b) in edges {
            let rows = 4;
            let (sa, sb) = (node_size[a], node_size[b]);
            // X = J_a^T (sa x rows, row-major), Y = J_b^T.
            let x = DMatrix::from_fn(sa, rows, |_, _| noise(&mut seed));
            let y = DMatrix::from_fn(sb, rows, |_, _| noise(&mut seed));
            let (oa, ob) = (pattern.node_offset(a), pattern.node_offset(b));
            let mut view = dense.view_mut((oa, oa), (sa, sa));
            view += &x * x.transpose();
            let mut view = dense.view_mut((ob, ob), (sb, sb));
            view += &y * y.transpose();
            let mut view = dense.view_mut((oa, ob), (sa, sb));
            view += &x * y.transpose();
            let mut view = dense.view_mut((ob, oa), (sb, sa));
            view += &y * x.transpose();
            let x_rows: Vec<f64> = x.transpose().iter().copied().collect();
            let y_rows: Vec<f64> = y.transpose().iter().copied().collect();
            pattern.add_product(&mut values, a, a, &x_rows, &x_rows, rows, 1.0);
            pattern.add_product(&mut values, b, b, &y_rows, &y_rows, rows, 1.0);
            pattern.add_product(&mut values, a, b, &x_rows, &y_rows, rows, 1.0);
        }
        let rhs = DVector::from_fn(dim, |_, _| noise(&mut seed));
        pattern.factor(&mut values).expect("definite");
        let solution = DVector::from_vec(pattern.solve(&values, rhs.as_slice()));
        let reference = dense.clone().cholesky().expect("definite").solve(&rhs);
        assert!((&solution - &reference).norm() < 1e-9 * reference.norm().max(1.0), "{solution} vs {reference}");
        assert!((dense * solution - rhs).norm() < 1e-9);
    }

    #[test]
    fn matches_dense_cholesky_on_a_ring_with_a_shared_node() {
        let mut edges: Vec<(usize, usize)> = (0..12).map(|i| (i, (i + 1) % 12)).collect();
        edges.extend((0..12).map(|i| (i, (i + 3) % 12)));
        edges.extend((0..12).map(|i| (i, 12)));
        let mut sizes = vec![6; 12];
        sizes.push(3);
        check(sizes, &edges, 7);
    }

    #[test]
    fn matches_dense_cholesky_on_dense_disconnected_and_mixed_sizes() {
        let all: Vec<(usize, usize)> = (0..7).flat_map(|a| (0..a).map(move |b| (a, b))).collect();
        check(vec![6, 1, 5, 6, 2, 6, 4], &all, 3);
        check(vec![6, 6, 6, 2], &[], 11);
        check(vec![6; 70], &(0..69).map(|i| (i, i + 1)).collect::<Vec<_>>(), 5);
    }

    #[test]
    fn minimum_degree_keeps_a_chain_and_a_ring_free_of_fill() {
        let chain = 70;
        let mut graph = BlockGraph::new(chain);
        for node in 1..chain {
            graph.add_edge(node - 1, node);
        }
        let pattern = BlockPattern::new(vec![6; chain], graph);
        assert_eq!(pattern.value_count(), (2 * chain - 1) * 36);
        // Closing the ring costs one extra block per column at most.
        let mut graph = BlockGraph::new(chain);
        for node in 0..chain {
            graph.add_edge(node, (node + 1) % chain);
        }
        let pattern = BlockPattern::new(vec![6; chain], graph);
        assert!(pattern.value_count() <= 3 * chain * 36, "{}", pattern.value_count());
    }

    #[test]
    fn indefinite_matrix_is_reported() {
        let pattern = BlockPattern::new(vec![2], BlockGraph::new(1));
        let mut values = vec![1.0, 2.0, 2.0, 1.0];
        assert!(pattern.factor(&mut values).is_err());
    }
}
