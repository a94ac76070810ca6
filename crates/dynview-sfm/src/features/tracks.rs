//! Feature tracks: verified pairwise matches joined by union-find into multi-view tracks.

/// A feature of an image: `(image index, feature index)`.
pub type FeatureRef = (usize, u32);

struct UnionFind {
    parent: Vec<u32>,
}

impl UnionFind {
    fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let up = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = up;
            x = up;
        }
        x
    }

    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.parent[ra.max(rb) as usize] = ra.min(rb);
        }
    }
}

/// Tracks of at least two images; a track that would see one image twice is dropped (its
/// matches disagree).
#[derive(Clone, Debug, Default)]
pub struct Tracks {
    /// Each track's features, sorted by image.
    pub tracks: Vec<Vec<FeatureRef>>,
    /// Per image, per feature: its track.
    pub track_of: Vec<Vec<Option<u32>>>,
}

impl Tracks {
    /// Joins `pairs` (image a, image b, matches `[feature in a, feature in b]`) over images with
    /// `feature_counts[i]` features each.
    pub fn build(feature_counts: &[usize], pairs: &[(usize, usize, Vec<[u32; 2]>)]) -> Self {
        let mut offset = Vec::with_capacity(feature_counts.len() + 1);
        let mut total = 0u32;
        for &n in feature_counts {
            offset.push(total);
            total += n as u32;
        }
        let mut uf = UnionFind { parent: (0..total).collect() };
        let mut used = vec![false; total as usize];
        for (a, b, matches) in pairs {
            for m in matches {
                let (x, y) = (offset[*a] + m[0], offset[*b] + m[1]);
                uf.union(x, y);
                used[x as usize] = true;
                used[y as usize] = true;
            }
        }
        let mut members: std::collections::HashMap<u32, Vec<FeatureRef>> = std::collections::HashMap::new();
        for (image, &n) in feature_counts.iter().enumerate() {
            for f in 0..n as u32 {
                let node = offset[image] + f;
                if used[node as usize] {
                    members.entry(uf.find(node)).or_default().push((image, f));
                }
            }
        }
        let mut roots: Vec<u32> = members.keys().copied().collect();
        roots.sort_unstable();
        let mut out = Tracks { tracks: Vec::new(), track_of: feature_counts.iter().map(|&n| vec![None; n]).collect() };
        for root in roots {
            let track = &members[&root];
            let consistent = track.windows(2).all(|w| w[0].0 != w[1].0);
            if track.len() < 2 || !consistent {
                continue;
            }
            let id = out.tracks.len() as u32;
            for &(image, f) in track {
                out.track_of[image][f as usize] = Some(id);
            }
            out.tracks.push(track.clone());
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joins_chains_and_drops_contradictions() {
        // 0-1-2 chain of feature 0; feature 1 of image 0 matches two features of image 1.
        let pairs = vec![(0, 1, vec![[0, 0], [1, 1]]), (1, 2, vec![[0, 3]]), (0, 2, vec![[1, 1]]), (2, 1, vec![[1, 2]])];
        let t = Tracks::build(&[2, 3, 4], &pairs);
        assert_eq!(t.tracks, vec![vec![(0, 0), (1, 0), (2, 3)]]);
        assert_eq!(t.track_of[2][3], Some(0));
        assert_eq!(t.track_of[0][1], None);
    }
}
