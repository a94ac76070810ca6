//! A time step's cloud as a binary PLY file, for inspection in other tools (MeshLab,
//! CloudCompare, Blender): `dynview export-ply`.

use dynview_core::scene::PointCloud;

/// Encodes `cloud` as a little-endian binary PLY with `x y z` (float) and `red green blue`
/// (uchar) per vertex; `comment` (one line) goes into the header.
pub fn encode_ply(cloud: &PointCloud, comment: &str) -> Vec<u8> {
    let comment: String = comment.chars().filter(|c| !c.is_control()).collect();
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment {comment}\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n",
        cloud.len()
    );
    let mut out = Vec::with_capacity(header.len() + cloud.len() * 15);
    out.extend_from_slice(header.as_bytes());
    for (p, c) in cloud.positions_world.iter().zip(&cloud.colors) {
        for v in p {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_header_counts_the_vertices_and_the_body_holds_15_bytes_each() {
        let cloud = PointCloud { positions_world: vec![[1.0, -2.0, 3.5], [0.0, 0.25, 9.0]], colors: vec![[255, 0, 7], [1, 2, 3]] };
        let bytes = encode_ply(&cloud, "time step 3\nof x");
        let text = String::from_utf8_lossy(&bytes);
        let end = text.find("end_header\n").expect("header") + "end_header\n".len();
        assert!(text[..end].contains("element vertex 2\n"));
        assert!(text[..end].contains("comment time step 3of x\n"), "control characters are dropped from the comment");
        let body = &bytes[end..];
        assert_eq!(body.len(), 2 * 15);
        assert_eq!(f32::from_le_bytes(body[4..8].try_into().unwrap()), -2.0);
        assert_eq!(&body[12..15], &[255, 0, 7]);
        assert_eq!(f32::from_le_bytes(body[23..27].try_into().unwrap()), 9.0);
    }
}
