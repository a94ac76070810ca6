//! A directed graph of source files and its circles (strongly connected components of more
//! than one file), found with Tarjan's algorithm.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

/// Files as nodes; an edge `a -> b` means file `a` uses names defined in file `b`.
#[derive(Debug, Default)]
pub struct FileGraph {
    /// The files, indexed by node.
    pub files: Vec<PathBuf>,
    /// `(from, to)` -> the names `from` takes from `to`.
    pub edges: BTreeMap<(usize, usize), BTreeSet<String>>,
}

impl FileGraph {
    /// The node of `file`, added when new.
    pub fn node(&mut self, file: PathBuf) -> usize {
        if let Some(i) = self.files.iter().position(|f| *f == file) {
            return i;
        }
        self.files.push(file);
        self.files.len() - 1
    }

    /// Records that `from` uses `name` defined in `to` (self-uses are not edges).
    pub fn add_edge(&mut self, from: usize, to: usize, name: &str) {
        if from != to {
            self.edges.entry((from, to)).or_default().insert(name.to_owned());
        }
    }

    /// Every circle: the node sets of the strongly connected components with two or more
    /// nodes, each sorted, in order of their first node.
    pub fn circles(&self) -> Vec<Vec<usize>> {
        let n = self.files.len();
        let mut successors = vec![Vec::new(); n];
        for &(a, b) in self.edges.keys() {
            successors[a].push(b);
        }
        let mut tarjan = Tarjan {
            successors,
            index: vec![None; n],
            low: vec![0; n],
            on_stack: vec![false; n],
            stack: Vec::new(),
            next: 0,
            components: Vec::new(),
        };
        for v in 0..n {
            if tarjan.index[v].is_none() {
                tarjan.visit(v);
            }
        }
        let mut circles: Vec<Vec<usize>> = tarjan.components.into_iter().filter(|c| c.len() > 1).collect();
        for c in &mut circles {
            c.sort_unstable();
        }
        circles.sort();
        circles
    }
}

/// Tarjan's strongly connected components (recursive; source trees are shallow enough).
struct Tarjan {
    successors: Vec<Vec<usize>>,
    index: Vec<Option<usize>>,
    low: Vec<usize>,
    on_stack: Vec<bool>,
    stack: Vec<usize>,
    next: usize,
    components: Vec<Vec<usize>>,
}

impl Tarjan {
    fn visit(&mut self, v: usize) {
        self.index[v] = Some(self.next);
        self.low[v] = self.next;
        self.next += 1;
        self.stack.push(v);
        self.on_stack[v] = true;
        for i in 0..self.successors[v].len() {
            let w = self.successors[v][i];
            match self.index[w] {
                None => {
                    self.visit(w);
                    self.low[v] = self.low[v].min(self.low[w]);
                }
                Some(w_index) if self.on_stack[w] => self.low[v] = self.low[v].min(w_index),
                Some(_) => {}
            }
        }
        if Some(self.low[v]) == self.index[v] {
            let mut component = Vec::new();
            while let Some(w) = self.stack.pop() {
                self.on_stack[w] = false;
                component.push(w);
                if w == v {
                    break;
                }
            }
            self.components.push(component);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn graph(n: usize, edges: &[(usize, usize)]) -> FileGraph {
        let mut g = FileGraph::default();
        for i in 0..n {
            g.node(PathBuf::from(format!("f{i}")));
        }
        for &(a, b) in edges {
            g.add_edge(a, b, "x");
        }
        g
    }

    #[test]
    fn a_chain_has_no_circle() {
        assert!(graph(4, &[(0, 1), (1, 2), (2, 3), (0, 3)]).circles().is_empty());
    }

    #[test]
    fn circles_are_found_with_every_member() {
        let g = graph(6, &[(0, 1), (1, 2), (2, 0), (2, 3), (4, 5), (5, 4)]);
        assert_eq!(g.circles(), vec![vec![0, 1, 2], vec![4, 5]]);
    }

    #[test]
    fn self_uses_are_not_edges() {
        let mut g = graph(1, &[]);
        g.add_edge(0, 0, "x");
        assert!(g.edges.is_empty());
    }
}
