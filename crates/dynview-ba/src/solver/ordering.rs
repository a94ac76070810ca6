//! The fill-reducing elimination order of the reduced camera system: a greedy minimum-degree
//! ordering on the block graph (one node per free image or camera), run on bitset adjacency so
//! that eliminating a node (joining its neighbours into a clique) costs a few word operations
//! per neighbour.

/// Adjacency of the block graph as one bitset row per node.
pub(crate) struct BlockGraph {
    pub(super) node_count: usize,
    words: usize,
    bits: Vec<u64>,
}

impl BlockGraph {
    /// A graph on `node_count` nodes without edges.
    pub(crate) fn new(node_count: usize) -> Self {
        let words = node_count.div_ceil(64);
        Self { node_count, words, bits: vec![0; node_count * words] }
    }

    /// Records that blocks `a` and `b` interact (a no-op for `a == b`).
    pub(crate) fn add_edge(&mut self, a: usize, b: usize) {
        if a != b {
            self.bits[a * self.words + b / 64] |= 1 << (b % 64);
            self.bits[b * self.words + a / 64] |= 1 << (a % 64);
        }
    }
}

/// Greedy minimum-degree elimination on the bitset graph; returns the order and, for each
/// eliminated node, its neighbours at elimination (the rows of its factor column).
pub(super) fn minimum_degree_order(graph: BlockGraph) -> (Vec<usize>, Vec<Vec<usize>>) {
    let BlockGraph { node_count, words, bits: mut adjacency } = graph;
    let mut alive_bits = vec![0u64; words];
    for node in 0..node_count {
        alive_bits[node / 64] |= 1 << (node % 64);
    }
    let mut alive = vec![true; node_count];
    let mut degree: Vec<u32> =
        adjacency.chunks_exact(words.max(1)).take(node_count).map(|row| row.iter().map(|w| w.count_ones()).sum()).collect();
    let mut order = Vec::with_capacity(node_count);
    let mut neighbours = Vec::with_capacity(node_count);
    let mut clique = vec![0u64; words];
    for _ in 0..node_count {
        let Some(node) = (0..node_count).filter(|&n| alive[n]).min_by_key(|&n| degree[n]) else { break };
        alive[node] = false;
        alive_bits[node / 64] &= !(1 << (node % 64));
        for (word, (edges, live)) in clique.iter_mut().zip(adjacency[node * words..(node + 1) * words].iter().zip(&alive_bits)) {
            *word = edges & live;
        }
        let members: Vec<usize> = (0..words)
            .flat_map(|w| {
                let word = clique[w];
                (0..64).filter(move |bit| word & (1 << bit) != 0).map(move |bit| w * 64 + bit)
            })
            .collect();
        for &member in &members {
            let row = &mut adjacency[member * words..(member + 1) * words];
            for ((edge, &joined), &live) in row.iter_mut().zip(&clique).zip(&alive_bits) {
                *edge = (*edge | joined) & live;
            }
            row[member / 64] &= !(1 << (member % 64));
            degree[member] = row.iter().map(|w| w.count_ones()).sum();
        }
        order.push(node);
        neighbours.push(members);
    }
    (order, neighbours)
}
