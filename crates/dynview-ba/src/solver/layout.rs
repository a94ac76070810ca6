//! Which parameters are unknowns, how they are numbered, and the structure of the reduced
//! camera system.
//!
//! Camera-side unknowns come in nodes: one per free image that is observed or tied to another
//! image by a prior (6 unknowns: angle-axis, then centre), and one per camera whose intrinsics
//! are refined and that is observed (the free intrinsics in the order `[focal, cx, cy, k1, k2]`).
//! Observations are grouped by point; a free point with observations carries 3 unknowns that
//! the Schur complement eliminates.

use std::ops::Range;

use nalgebra::{Vector2, Vector3};

use super::block_cholesky::{BlockPattern, BlockSlot};
use super::ordering::BlockGraph;
use crate::options::Options;
use crate::pose::PoseParameters;
use crate::problem::Problem;
use crate::projection::{ImageFrame, pixel_from_camera};

/// Unknowns of one image pose: angle-axis (3) then centre (3).
pub(crate) const POSE_UNKNOWNS: usize = 6;

/// What a camera-side node stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NodeKind {
    /// The pose of an image.
    Image(usize),
    /// The free intrinsics of a camera.
    Camera(usize),
}

/// One observed point and its observations.
#[derive(Debug, Clone)]
pub(crate) struct PointGroup {
    /// Index into `Problem::points_world`.
    pub point: usize,
    /// Whether the point is an unknown.
    pub free: bool,
    /// Its observations, a range of [`Layout::observations`].
    pub observations: Range<usize>,
    /// The distinct camera-side nodes its observations touch (free points only), a range of
    /// [`Layout::group_nodes`].
    pub nodes: Range<usize>,
    /// Offset of its coupling blocks (one `node size x 3` block per node) in the coupling buffer.
    pub coupling_start: usize,
    /// Start of its node pairs `(k, l <= k)`, in that order, in [`Layout::pair_slots`].
    pub pairs_start: usize,
}

/// One used observation with its unknowns resolved.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LaidObservation {
    /// Index of the image.
    pub image: usize,
    /// Index of the image's camera.
    pub camera: usize,
    /// Index of the point.
    pub point: usize,
    /// The measured pixel.
    pub pixel: Vector2<f64>,
    /// The image's node, when its pose is free.
    pub image_node: Option<usize>,
    /// The camera's node, when its intrinsics are free.
    pub camera_node: Option<usize>,
    /// For a free point: where `image_node` sits in its group's node list.
    pub image_local: Option<usize>,
    /// For a free point: where `camera_node` sits in its group's node list.
    pub camera_local: Option<usize>,
}

/// The numbering of all unknowns and the reduced system's structure.
pub(crate) struct Layout {
    /// Per image, its node when its pose is an unknown.
    pub image_node: Vec<Option<usize>>,
    /// Per node, what it stands for.
    pub node_kind: Vec<NodeKind>,
    /// Per camera, its refined intrinsics as indices into `[focal, cx, cy, k1, k2]`: those the
    /// options refine and the camera does not hold.
    pub free_intrinsics: Vec<Vec<usize>>,
    /// Observed points, each with its observations.
    pub groups: Vec<PointGroup>,
    /// Used observations, grouped by point.
    pub observations: Vec<LaidObservation>,
    /// Concatenated node lists of the free points.
    pub group_nodes: Vec<usize>,
    /// Length of the coupling buffer.
    pub coupling_len: usize,
    /// Observations left out because their point was not in front of the camera at the start.
    pub excluded_observations: usize,
    /// Number of free, observed points.
    pub free_points: usize,
    /// Structure of the reduced camera system.
    pub pattern: BlockPattern,
    /// For each free point group and each pair of its nodes, where the pair's block of the
    /// reduced system lives (looked up once instead of every iteration).
    pub pair_slots: Vec<Option<BlockSlot>>,
}

impl Layout {
    /// Numbers the unknowns of a validated problem.
    pub(crate) fn new(problem: &Problem, options: &Options) -> Self {
        let refined: Vec<usize> = [
            (options.refine_focal, 0),
            (options.refine_principal_point, 1),
            (options.refine_principal_point, 2),
            (options.refine_distortion, 3),
            (options.refine_distortion, 4),
        ]
        .into_iter()
        .filter_map(|(refine, index)| refine.then_some(index))
        .collect();
        let free_intrinsics: Vec<Vec<usize>> = (0..problem.cameras.len())
            .map(|camera| refined.iter().copied().filter(|&index| !problem.held(camera).holds(index)).collect())
            .collect();

        // Observations whose point is in front of the camera at the start.
        let frames: Vec<ImageFrame> = problem.images.iter().map(|pose| ImageFrame::new(&PoseParameters::from_rigid(pose))).collect();
        let used: Vec<bool> = problem
            .observations
            .iter()
            .map(|o| {
                let camera = &problem.cameras[problem.image_camera[o.image]];
                pixel_from_camera(camera, &frames[o.image].point_camera(&Vector3::from(problem.points_world[o.point]))).is_some()
            })
            .collect();
        let excluded_observations = used.iter().filter(|&&u| !u).count();

        // Nodes: free images that are observed or in a prior, then observed cameras.
        let mut image_used = vec![false; problem.images.len()];
        let mut camera_used = vec![false; problem.cameras.len()];
        for (observation, _) in problem.observations.iter().zip(&used).filter(|(_, u)| **u) {
            image_used[observation.image] = true;
            camera_used[problem.image_camera[observation.image]] = true;
        }
        for prior in problem.priors.iter().filter(|p| p.image_a != p.image_b) {
            image_used[prior.image_a] = true;
            image_used[prior.image_b] = true;
        }
        let mut node_kind = Vec::new();
        let mut node_size = Vec::new();
        let image_node: Vec<Option<usize>> = (0..problem.images.len())
            .map(|image| {
                (image_used[image] && !problem.image_fixed[image]).then(|| {
                    node_kind.push(NodeKind::Image(image));
                    node_size.push(POSE_UNKNOWNS);
                    node_kind.len() - 1
                })
            })
            .collect();
        let camera_node: Vec<Option<usize>> = (0..problem.cameras.len())
            .map(|camera| {
                (camera_used[camera] && !free_intrinsics[camera].is_empty()).then(|| {
                    node_kind.push(NodeKind::Camera(camera));
                    node_size.push(free_intrinsics[camera].len());
                    node_kind.len() - 1
                })
            })
            .collect();
        let mut graph = BlockGraph::new(node_kind.len());

        // Group the used observations by point (counting sort keeps the input order within a point).
        let mut start_of_point = vec![0usize; problem.points_world.len() + 1];
        for (observation, _) in problem.observations.iter().zip(&used).filter(|(_, u)| **u) {
            start_of_point[observation.point + 1] += 1;
        }
        for point in 0..problem.points_world.len() {
            start_of_point[point + 1] += start_of_point[point];
        }
        let mut sorted = vec![0usize; start_of_point[problem.points_world.len()]];
        let mut cursor = start_of_point.clone();
        for (index, observation) in problem.observations.iter().enumerate().filter(|(i, _)| used[*i]) {
            sorted[cursor[observation.point]] = index;
            cursor[observation.point] += 1;
        }

        let mut groups = Vec::new();
        let mut observations = Vec::with_capacity(sorted.len());
        let mut group_nodes = Vec::new();
        let mut coupling_len = 0;
        let mut free_points = 0;
        for point in 0..problem.points_world.len() {
            let members = &sorted[start_of_point[point]..start_of_point[point + 1]];
            if members.is_empty() {
                continue;
            }
            let free = !problem.point_fixed[point];
            let nodes_start = group_nodes.len();
            let observations_start = observations.len();
            for &index in members {
                let o = &problem.observations[index];
                let camera = problem.image_camera[o.image];
                let (image_node, camera_node) = (image_node[o.image], camera_node[camera]);
                if let (Some(a), Some(b)) = (image_node, camera_node) {
                    graph.add_edge(a, b);
                }
                let mut local = |node: Option<usize>| {
                    let node = node.filter(|_| free)?;
                    let nodes = &group_nodes[nodes_start..];
                    Some(nodes.iter().position(|&n| n == node).unwrap_or_else(|| {
                        group_nodes.push(node);
                        group_nodes.len() - 1 - nodes_start
                    }))
                };
                let image_local = local(image_node);
                let camera_local = local(camera_node);
                observations.push(LaidObservation {
                    image: o.image,
                    camera,
                    point,
                    pixel: Vector2::from(o.pixel),
                    image_node,
                    camera_node,
                    image_local,
                    camera_local,
                });
            }
            let nodes = nodes_start..group_nodes.len();
            for (i, &a) in group_nodes[nodes.clone()].iter().enumerate() {
                for &b in &group_nodes[nodes_start..nodes_start + i] {
                    graph.add_edge(a, b);
                }
            }
            let coupling_start = coupling_len;
            coupling_len += group_nodes[nodes.clone()].iter().map(|&n| node_size[n] * 3).sum::<usize>();
            free_points += usize::from(free);
            groups.push(PointGroup {
                point,
                free,
                observations: observations_start..observations.len(),
                nodes,
                coupling_start,
                pairs_start: 0,
            });
        }
        for prior in &problem.priors {
            if let (Some(a), Some(b)) = (image_node[prior.image_a], image_node[prior.image_b]) {
                graph.add_edge(a, b);
            }
        }
        let pattern = BlockPattern::new(node_size, graph);
        let mut pair_slots = Vec::new();
        for group in &mut groups {
            group.pairs_start = pair_slots.len();
            let nodes = &group_nodes[group.nodes.clone()];
            for (k, &node_k) in nodes.iter().enumerate() {
                pair_slots.extend(nodes[..=k].iter().map(|&node_l| pattern.slot(node_k, node_l)));
            }
        }
        Self {
            image_node,
            node_kind,
            free_intrinsics,
            groups,
            observations,
            group_nodes,
            coupling_len,
            excluded_observations,
            free_points,
            pattern,
            pair_slots,
        }
    }

    /// Number of unknowns in the reduced camera system.
    pub(crate) fn camera_unknowns(&self) -> usize {
        self.pattern.dim()
    }
}
