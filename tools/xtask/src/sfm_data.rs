//! Ground truth and models of the SfM benchmark: camera poses keyed by image name
//! (`<camera folder>/<file>`), read from COLMAP text models and Middlebury `_par.txt` files
//! (the Qualisys calibration is in `sfm_qualisys`).

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, bail};
use dynview_core::colmap::{CameraModel, ColmapModel};
use dynview_core::{Intrinsics, Rigid3};
use glam::DVec3;

/// `camera_from_world` poses keyed by image name.
pub type Poses = BTreeMap<String, Rigid3>;

/// Tolerance on `R R^T = I` and `det R = 1` for ground-truth rotations read from text.
const ROTATION_TOLERANCE: f64 = 1e-6;

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

/// One line of a Middlebury `_par.txt` file.
#[derive(Clone, Debug, PartialEq)]
pub struct ParCamera {
    /// Image file name, e.g. `templeSR0001.png`.
    pub name: String,
    /// Intrinsics from `K` (the file gives no pixel-centre convention; taken as is).
    pub intrinsics: Intrinsics,
    /// World-to-camera pose `[R t]`.
    pub camera_from_world: Rigid3,
}

/// Parses a Middlebury `_par.txt`: a first line with the image count, then per image
/// `name k11 k12 k13 k21 k22 k23 k31 k32 k33 r11 r12 r13 r21 r22 r23 r31 r32 r33 t1 t2 t3`,
/// the projection being `K [R t]` (world to camera). `file` names the source in errors.
pub fn parse_middlebury_par(text: &str, file: &str) -> anyhow::Result<Vec<ParCamera>> {
    const FIELDS: usize = 22;
    const FIELD_NAMES: [&str; FIELDS] = [
        "name", "k11", "k12", "k13", "k21", "k22", "k23", "k31", "k32", "k33", "r11", "r12", "r13", "r21", "r22", "r23", "r31", "r32",
        "r33", "t1", "t2", "t3",
    ];
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let (_, count_line) = lines.next().with_context(|| format!("{file}: empty"))?;
    let count: usize = count_line.trim().parse().with_context(|| format!("{file}:1: field `count`: not a number: {count_line:?}"))?;
    let mut cameras = Vec::with_capacity(count.min(10_000));
    for (index, line) in lines {
        let at = || format!("{file}:{}", index + 1);
        let tokens: Vec<&str> = line.split_whitespace().collect();
        if tokens.len() != FIELDS {
            bail!("{}: expected {FIELDS} fields (name, K, R, t), found {}", at(), tokens.len());
        }
        let mut v = [0.0; FIELDS];
        for k in 1..FIELDS {
            v[k] = tokens[k]
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .with_context(|| format!("{}: field `{}`: not a finite number: {:?}", at(), FIELD_NAMES[k], tokens[k]))?;
        }
        let [k11, k12, k13, k21, k22, k23, k31, k32, k33] = [v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9]];
        if k21 != 0.0 || k31 != 0.0 || k32 != 0.0 || k33 != 1.0 || k12.abs() > 1e-9 * k11.abs() {
            bail!("{}: field `K`: expected [[fx 0 cx] [0 fy cy] [0 0 1]], found {:?}", at(), &v[1..10]);
        }
        let intrinsics = Intrinsics { fx: k11, fy: k22, cx: k13, cy: k23 };
        if !intrinsics.is_valid() {
            bail!("{}: field `K`: focal lengths must be positive", at());
        }
        let rows = [[v[10], v[11], v[12]], [v[13], v[14], v[15]], [v[16], v[17], v[18]]];
        let camera_from_world = Rigid3::from_rotation_rows(rows, [v[19], v[20], v[21]]);
        if !camera_from_world.is_proper_rigid(ROTATION_TOLERANCE) {
            bail!("{}: field `R`: not a rotation (orthonormal with determinant +1)", at());
        }
        cameras.push(ParCamera { name: tokens[0].to_owned(), intrinsics, camera_from_world });
    }
    if cameras.len() != count {
        bail!("{file}: the first line announces {count} images, found {}", cameras.len());
    }
    Ok(cameras)
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
            let projected = colmap_project(camera.model, &camera.params, in_camera.x / in_camera.z, in_camera.y / in_camera.z);
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

/// Pixel position (COLMAP's convention) of the normalised image point `(u, v)`, as COLMAP's
/// `models.h` maps it, parameters in its order.
fn colmap_project(model: CameraModel, params: &[f64], u: f64, v: f64) -> [f64; 2] {
    let r2 = u * u + v * v;
    let (fx, fy, cx, cy, du, dv) = match model {
        CameraModel::SimplePinhole => (params[0], params[0], params[1], params[2], 0.0, 0.0),
        CameraModel::Pinhole => (params[0], params[1], params[2], params[3], 0.0, 0.0),
        CameraModel::SimpleRadial => (params[0], params[0], params[1], params[2], u * params[3] * r2, v * params[3] * r2),
        CameraModel::Radial => {
            let radial = params[3] * r2 + params[4] * r2 * r2;
            (params[0], params[0], params[1], params[2], u * radial, v * radial)
        }
        CameraModel::OpenCv => {
            let (k1, k2, p1, p2) = (params[4], params[5], params[6], params[7]);
            let radial = k1 * r2 + k2 * r2 * r2;
            let du = u * radial + 2.0 * p1 * u * v + p2 * (r2 + 2.0 * u * u);
            let dv = v * radial + 2.0 * p2 * u * v + p1 * (r2 + 2.0 * v * v);
            (params[0], params[1], params[2], params[3], du, dv)
        }
    };
    [fx * (u + du) + cx, fy * (v + dv) + cy]
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynview_core::colmap::{ColmapCamera, ColmapImage, ColmapPoint3D, Point2D};

    const TEMPLE_PAR: &str = include_str!("../../../tests/data/middlebury-temple-sparse-ring/templeSR_par.txt");

    #[test]
    fn parses_the_temple_ring() {
        let cameras = parse_middlebury_par(TEMPLE_PAR, "templeSR_par.txt").unwrap();
        assert_eq!(cameras.len(), 16);
        let first = &cameras[0];
        assert_eq!(first.name, "templeSR0001.png");
        assert_eq!(first.intrinsics, Intrinsics { fx: 1520.4, fy: 1525.9, cx: 302.32, cy: 246.87 });
        assert_eq!(first.camera_from_world.rotation_rows()[0], [0.02187598221295043, 0.9832968088621312, -0.18068986436368856]);
        assert_eq!(first.camera_from_world.translation, DVec3::new(-0.0726637729648, 0.0223360353405, 0.614604845959));
        // Every camera looks at the object: its bounding box centre (README.txt) lies in front,
        // about 0.6 m away, and projects into the 640x480 image.
        let object = DVec3::new(-0.022356, 0.10181, 0.0251455);
        for c in &cameras {
            let in_camera = c.camera_from_world.transform_point(object);
            assert!((0.4..0.8).contains(&in_camera.z), "{}: depth {}", c.name, in_camera.z);
            let pixel = c.intrinsics.project(in_camera).unwrap();
            assert!((0.0..640.0).contains(&pixel.x) && (0.0..480.0).contains(&pixel.y), "{}: {pixel}", c.name);
        }
    }

    #[test]
    fn par_errors_name_line_and_field() {
        let line = "a.png 1 0 1 0 1 1 0 0 1 1 0 0 0 1 0 0 0 1 0 0 0";
        assert_eq!(parse_middlebury_par(&format!("1\n{line}\n"), "p.txt").unwrap().len(), 1);
        let err = parse_middlebury_par(&format!("2\n{line}\n"), "p.txt").unwrap_err().to_string();
        assert!(err.contains("announces 2"), "{err}");
        let err = parse_middlebury_par(&format!("1\n{}\n", line.replace(" 1 0 0 0 1 0 0 0 1 0", " 1 0 0 0 1 0 0 0 x 0")), "p.txt")
            .unwrap_err()
            .to_string();
        assert!(err.contains("p.txt:2") && err.contains("`r33`"), "{err}");
        let err = parse_middlebury_par(&format!("1\n{}\n", line.replace(" 1 0 0 0 1 0 0 0 1 0", " 2 0 0 0 1 0 0 0 1 0")), "p.txt")
            .unwrap_err()
            .to_string();
        assert!(err.contains("`R`"), "{err}");
        let err = parse_middlebury_par("1\na.png 1 2\n", "p.txt").unwrap_err().to_string();
        assert!(err.contains("expected 22 fields"), "{err}");
    }

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
