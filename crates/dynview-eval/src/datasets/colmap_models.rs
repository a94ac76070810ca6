//! Ground truth and models of the SfM benchmark: camera poses keyed by image name
//! (`<camera folder>/<file>`) and reprojection errors recomputed from COLMAP models.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, bail};
use dynview_camera::pixel_from_normalized;
use dynview_core::Rigid3;
use dynview_interchange::colmap::ColmapModel;
use glam::DVec3;

/// `camera_from_world` poses keyed by image name.
pub type Poses = BTreeMap<String, Rigid3>;

/// Reads the COLMAP text model (`cameras.txt`, `images.txt`, `points3D.txt`) in `dir`.
pub fn read_colmap_text(dir: &Path) -> anyhow::Result<ColmapModel> {
    let read = |file: &str| {
        let path = dir.join(file);
        std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))
    };
    ColmapModel::from_text(&read("cameras.txt")?, &read("images.txt")?, &read("points3D.txt")?)
        .with_context(|| format!("COLMAP model in {}", dir.display()))
}

/// The `camera_from_world` pose of every image of `model`, by image name.
pub fn poses_from_colmap(model: &ColmapModel) -> Poses {
    model.images.values().map(|image| (image.name.clone(), image.camera_from_world)).collect()
}

/// Mean reprojection error of a model in pixels, recomputed from the model itself: every
/// observation of every 3D point is projected through its image's pose and camera (with the
/// camera model's distortion) and compared with the stored 2D point. Returns
/// `(mean_px, observations)`, or `None` when the model has no observations. Observations
/// behind their camera or naming missing images or 2D points count as errors of the model.
pub fn mean_reprojection_error_px(model: &ColmapModel) -> anyhow::Result<Option<(f64, usize)>> {
    let mut sum = 0.0;
    let mut count = 0usize;
    for (point_id, point) in &model.points3d {
        let world = DVec3::from_array(point.xyz);
        for &(image_id, index) in &point.track {
            let image = model.images.get(&image_id).with_context(|| format!("point {point_id}: track names missing image {image_id}"))?;
            let observed = image
                .points2d
                .get(index as usize)
                .with_context(|| format!("point {point_id}: image {image_id} has no 2D point {index}"))?;
            let camera = model.cameras.get(&image.camera_id).with_context(|| format!("image {image_id}: missing camera"))?;
            let in_camera = image.camera_from_world.transform_point(world);
            if in_camera.z <= 0.0 {
                bail!("point {point_id} lies behind image {image_id} ({})", image.name);
            }
            let normalized = [in_camera.x / in_camera.z, in_camera.y / in_camera.z];
            let projected = pixel_from_normalized(camera.model, &camera.params, normalized)
                .with_context(|| format!("camera {}: {} parameters for {}", image.camera_id, camera.params.len(), camera.model))?;
            sum += ((projected[0] - observed.xy[0]).powi(2) + (projected[1] - observed.xy[1]).powi(2)).sqrt();
            count += 1;
        }
    }
    Ok((count > 0).then(|| (sum / count as f64, count)))
}

/// Mean of the points' stored `ERROR` weighted by track length (what COLMAP itself reports as
/// the mean reprojection error), or `None` without observations.
pub fn track_weighted_error_px(model: &ColmapModel) -> Option<f64> {
    let (sum, count) = model.points3d.values().fold((0.0, 0usize), |(s, n), p| (s + p.error * p.track.len() as f64, n + p.track.len()));
    (count > 0).then(|| sum / count as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynview_interchange::colmap::{CameraModel, ColmapCamera, ColmapImage, ColmapPoint3D, Point2D};

    #[test]
    fn reprojection_error_is_recomputed_with_distortion() {
        let camera = ColmapCamera { model: CameraModel::SimpleRadial, width: 100, height: 100, params: vec![100.0, 50.0, 50.0, 0.1] };
        let pose = Rigid3::new(glam::DMat3::IDENTITY, DVec3::new(0.0, 0.0, 2.0));
        // The point (1, 0, 0) sits at u = 0.5, v = 0: distorted u = 0.5 (1 + 0.1 * 0.25).
        let exact = [100.0 * 0.5 * 1.025 + 50.0, 50.0];
        let mut model = ColmapModel::default();
        model.cameras.insert(1, camera);
        model.images.insert(
            1,
            ColmapImage {
                camera_id: 1,
                camera_from_world: pose,
                name: "c/0.png".into(),
                points2d: vec![Point2D { xy: exact, point3d_id: Some(1) }, Point2D { xy: [exact[0] + 3.0, 54.0], point3d_id: Some(1) }],
            },
        );
        model.points3d.insert(1, ColmapPoint3D { xyz: [1.0, 0.0, 0.0], rgb: [0; 3], error: 2.5, track: vec![(1, 0), (1, 1)] });
        let (mean, n) = mean_reprojection_error_px(&model).unwrap().unwrap();
        assert_eq!(n, 2);
        assert!((mean - 2.5).abs() < 1e-9, "{mean}");
        assert_eq!(track_weighted_error_px(&model), Some(2.5));
        model.points3d.get_mut(&1).unwrap().track.push((2, 0));
        assert!(mean_reprojection_error_px(&model).unwrap_err().to_string().contains("missing image 2"));
    }
}
