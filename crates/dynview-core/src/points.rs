//! Colored point clouds: the sparse points of one time step, as the scene package stores them
//! and the renderer projects them.

/// A colored point cloud of one time step.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointCloud {
    /// World positions.
    pub positions_world: Vec<[f32; 3]>,
    /// 8-bit colors, one per position.
    pub colors: Vec<[u8; 3]>,
}

impl PointCloud {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.positions_world.len()
    }

    /// True without points.
    pub fn is_empty(&self) -> bool {
        self.positions_world.is_empty()
    }

    /// Appends the points of `source` at `indices` (each below `source.len()`).
    pub fn extend_indexed(&mut self, source: &PointCloud, indices: impl IntoIterator<Item = usize>) {
        for i in indices {
            self.positions_world.push(source.positions_world[i]);
            self.colors.push(source.colors[i]);
        }
    }

    /// The points at `indices` (each below `len()`), in that order.
    pub fn select(&self, indices: impl IntoIterator<Item = usize>) -> PointCloud {
        let mut out = PointCloud::default();
        out.extend_indexed(self, indices);
        out
    }
}
