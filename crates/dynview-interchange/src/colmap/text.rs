//! COLMAP's text form: `cameras.txt`, `images.txt`, `points3D.txt`.
//!
//! One line per camera, two per image (the second lists the 2D points, possibly empty), one per
//! 3D point; `#` starts a comment. Numbers are written with Rust's shortest round-trip
//! formatting, so they read back exactly (rotations pass through a quaternion: about 1e-16).

use std::collections::BTreeMap;
use std::fmt::Write as _;

use super::{CameraModel, ColmapCamera, ColmapError, ColmapImage, ColmapModel, ColmapPoint3D, MAX_ENTRIES, Point2D};
use dynview_core::camera::Rigid3;
use dynview_core::rotation::{matrix_from_quaternion_wxyz, quaternion_wxyz_from_matrix};

struct Lines<'a> {
    file: &'a str,
    iter: std::iter::Peekable<std::iter::Enumerate<std::str::Lines<'a>>>,
}

impl<'a> Lines<'a> {
    fn new(file: &'a str, text: &'a str) -> Self {
        Self { file, iter: text.lines().enumerate().peekable() }
    }

    /// Next non-comment line (1-based number, content). `keep_empty` returns blank lines too
    /// (images.txt has an empty 2D-point line for images without points).
    fn next_line(&mut self, keep_empty: bool) -> Option<(usize, &'a str)> {
        for (i, line) in self.iter.by_ref() {
            let trimmed = line.trim();
            if trimmed.starts_with('#') || (!keep_empty && trimmed.is_empty()) {
                continue;
            }
            return Some((i + 1, trimmed));
        }
        None
    }

    fn err(&self, line: usize, field: &str, problem: impl Into<String>) -> ColmapError {
        ColmapError::Parse { file: self.file.to_owned(), line, field: field.to_owned(), problem: problem.into() }
    }
}

fn parse_field<T: std::str::FromStr>(lines: &Lines, line: usize, field: &str, token: Option<&str>) -> Result<T, ColmapError> {
    let token = token.ok_or_else(|| lines.err(line, field, "missing"))?;
    token.parse().map_err(|_| lines.err(line, field, format!("cannot parse {token:?}")))
}

fn parse_finite(lines: &Lines, line: usize, field: &str, token: Option<&str>) -> Result<f64, ColmapError> {
    let v: f64 = parse_field(lines, line, field, token)?;
    if !v.is_finite() {
        return Err(lines.err(line, field, "not finite"));
    }
    Ok(v)
}

/// Parses `cameras.txt`.
pub fn parse_cameras_txt(text: &str, file: &str) -> Result<BTreeMap<u32, ColmapCamera>, ColmapError> {
    let mut lines = Lines::new(file, text);
    let mut cameras = BTreeMap::new();
    while let Some((n, line)) = lines.next_line(false) {
        let mut tok = line.split_whitespace();
        let id: u32 = parse_field(&lines, n, "CAMERA_ID", tok.next())?;
        let model_name: String = parse_field(&lines, n, "MODEL", tok.next())?;
        let model = CameraModel::from_name(&model_name).ok_or_else(|| lines.err(n, "MODEL", format!("unsupported model {model_name}")))?;
        let width: u32 = parse_field(&lines, n, "WIDTH", tok.next())?;
        let height: u32 = parse_field(&lines, n, "HEIGHT", tok.next())?;
        let params = (0..model.param_count())
            .map(|i| parse_finite(&lines, n, &format!("PARAMS[{i}]"), tok.next()))
            .collect::<Result<Vec<_>, _>>()?;
        if tok.next().is_some() {
            return Err(lines.err(n, "PARAMS", format!("more than {} parameters for {model_name}", model.param_count())));
        }
        if cameras.len() >= MAX_ENTRIES || cameras.insert(id, ColmapCamera { model, width, height, params }).is_some() {
            return Err(lines.err(n, "CAMERA_ID", format!("duplicate id {id} or too many cameras")));
        }
    }
    Ok(cameras)
}

/// Parses `images.txt`.
pub fn parse_images_txt(text: &str, file: &str) -> Result<BTreeMap<u32, ColmapImage>, ColmapError> {
    let mut lines = Lines::new(file, text);
    let mut images = BTreeMap::new();
    while let Some((n, line)) = lines.next_line(false) {
        let mut tok = line.split_whitespace();
        let id: u32 = parse_field(&lines, n, "IMAGE_ID", tok.next())?;
        let q: [f64; 4] = [
            parse_finite(&lines, n, "QW", tok.next())?,
            parse_finite(&lines, n, "QX", tok.next())?,
            parse_finite(&lines, n, "QY", tok.next())?,
            parse_finite(&lines, n, "QZ", tok.next())?,
        ];
        let t = [
            parse_finite(&lines, n, "TX", tok.next())?,
            parse_finite(&lines, n, "TY", tok.next())?,
            parse_finite(&lines, n, "TZ", tok.next())?,
        ];
        let camera_id: u32 = parse_field(&lines, n, "CAMERA_ID", tok.next())?;
        let name: String = parse_field(&lines, n, "NAME", tok.next())?;
        let rotation = matrix_from_quaternion_wxyz(q).ok_or_else(|| lines.err(n, "QW QX QY QZ", "zero quaternion"))?;
        let (n2, points_line) = lines.next_line(true).unwrap_or((n + 1, ""));
        let values: Vec<&str> = points_line.split_whitespace().collect();
        if !values.len().is_multiple_of(3) {
            return Err(lines.err(n2, "POINTS2D", "expected triples X Y POINT3D_ID"));
        }
        let mut points2d = Vec::with_capacity(values.len() / 3);
        for (k, chunk) in values.chunks(3).enumerate() {
            let x = parse_finite(&lines, n2, &format!("POINTS2D[{k}].X"), Some(chunk[0]))?;
            let y = parse_finite(&lines, n2, &format!("POINTS2D[{k}].Y"), Some(chunk[1]))?;
            let pid: i64 = parse_field(&lines, n2, &format!("POINTS2D[{k}].POINT3D_ID"), Some(chunk[2]))?;
            points2d.push(Point2D { xy: [x, y], point3d_id: (pid >= 0).then_some(pid as u64) });
        }
        let image = ColmapImage { camera_id, camera_from_world: Rigid3::new(rotation, glam::DVec3::from_array(t)), name, points2d };
        if images.len() >= MAX_ENTRIES || images.insert(id, image).is_some() {
            return Err(lines.err(n, "IMAGE_ID", format!("duplicate id {id} or too many images")));
        }
    }
    Ok(images)
}

/// Parses `points3D.txt`.
pub fn parse_points3d_txt(text: &str, file: &str) -> Result<BTreeMap<u64, ColmapPoint3D>, ColmapError> {
    let mut lines = Lines::new(file, text);
    let mut points = BTreeMap::new();
    while let Some((n, line)) = lines.next_line(false) {
        let mut tok = line.split_whitespace();
        let id: u64 = parse_field(&lines, n, "POINT3D_ID", tok.next())?;
        let xyz = [
            parse_finite(&lines, n, "X", tok.next())?,
            parse_finite(&lines, n, "Y", tok.next())?,
            parse_finite(&lines, n, "Z", tok.next())?,
        ];
        let rgb =
            [parse_field(&lines, n, "R", tok.next())?, parse_field(&lines, n, "G", tok.next())?, parse_field(&lines, n, "B", tok.next())?];
        let error: f64 = parse_field(&lines, n, "ERROR", tok.next())?;
        let rest: Vec<&str> = tok.collect();
        if !rest.len().is_multiple_of(2) {
            return Err(lines.err(n, "TRACK", "expected pairs IMAGE_ID POINT2D_IDX"));
        }
        let track = rest
            .chunks(2)
            .enumerate()
            .map(|(k, c)| {
                Ok((
                    parse_field(&lines, n, &format!("TRACK[{k}].IMAGE_ID"), Some(c[0]))?,
                    parse_field(&lines, n, &format!("TRACK[{k}].POINT2D_IDX"), Some(c[1]))?,
                ))
            })
            .collect::<Result<Vec<_>, ColmapError>>()?;
        if points.len() >= MAX_ENTRIES || points.insert(id, ColmapPoint3D { xyz, rgb, error, track }).is_some() {
            return Err(lines.err(n, "POINT3D_ID", format!("duplicate id {id} or too many points")));
        }
    }
    Ok(points)
}

impl ColmapModel {
    /// Parses the three text files and checks that images name existing cameras.
    pub fn from_text(cameras_txt: &str, images_txt: &str, points3d_txt: &str) -> Result<Self, ColmapError> {
        Self::from_text_named([cameras_txt, images_txt, points3d_txt], ["cameras.txt", "images.txt", "points3D.txt"])
    }

    /// [`ColmapModel::from_text`] with the names (or paths) errors give the three files.
    pub(crate) fn from_text_named(texts: [&str; 3], files: [&str; 3]) -> Result<Self, ColmapError> {
        let model = Self {
            cameras: parse_cameras_txt(texts[0], files[0])?,
            images: parse_images_txt(texts[1], files[1])?,
            points3d: parse_points3d_txt(texts[2], files[2])?,
        };
        model.check_references(files[1])?;
        Ok(model)
    }

    /// `cameras.txt` contents.
    pub fn cameras_txt(&self) -> String {
        let mut s = String::from("# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n");
        let _ = writeln!(s, "# Number of cameras: {}", self.cameras.len());
        for (id, c) in &self.cameras {
            let _ = write!(s, "{id} {} {} {}", c.model.name(), c.width, c.height);
            for p in &c.params {
                let _ = write!(s, " {p}");
            }
            s.push('\n');
        }
        s
    }

    /// `images.txt` contents.
    pub fn images_txt(&self) -> String {
        let mut s = String::from(
            "# Image list with two lines of data per image:\n#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n#   POINTS2D[] as (X, Y, POINT3D_ID)\n",
        );
        let _ = writeln!(s, "# Number of images: {}", self.images.len());
        for (id, im) in &self.images {
            let q = quaternion_wxyz_from_matrix(im.camera_from_world.rotation);
            let t = im.camera_from_world.translation;
            let _ = writeln!(s, "{id} {} {} {} {} {} {} {} {} {}", q[0], q[1], q[2], q[3], t.x, t.y, t.z, im.camera_id, im.name);
            let points: Vec<String> =
                im.points2d.iter().map(|p| format!("{} {} {}", p.xy[0], p.xy[1], p.point3d_id.map_or(-1, |v| v as i64))).collect();
            let _ = writeln!(s, "{}", points.join(" "));
        }
        s
    }

    /// `points3D.txt` contents.
    pub fn points3d_txt(&self) -> String {
        let mut s = String::from(
            "# 3D point list with one line of data per point:\n#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n",
        );
        let _ = writeln!(s, "# Number of points: {}", self.points3d.len());
        for (id, p) in &self.points3d {
            let _ = write!(s, "{id} {} {} {} {} {} {} {}", p.xyz[0], p.xyz[1], p.xyz[2], p.rgb[0], p.rgb[1], p.rgb[2], p.error);
            for (image_id, idx) in &p.track {
                let _ = write!(s, " {image_id} {idx}");
            }
            s.push('\n');
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colmap::tests::sample_model as model;
    use dynview_core::camera::Intrinsics;

    #[test]
    fn text_round_trip() {
        let m = model();
        let back = ColmapModel::from_text(&m.cameras_txt(), &m.images_txt(), &m.points3d_txt()).unwrap();
        assert_eq!(back.cameras, m.cameras);
        assert_eq!(back.points3d, m.points3d);
        for (id, im) in &m.images {
            let b = &back.images[id];
            assert_eq!((b.name.as_str(), b.camera_id, &b.points2d), (im.name.as_str(), im.camera_id, &im.points2d));
            let d = b.camera_from_world.rotation - im.camera_from_world.rotation;
            assert!(d.to_cols_array().iter().all(|v| v.abs() < 1e-14));
        }
    }

    #[test]
    fn half_pixel_convention() {
        let k = Intrinsics { fx: 500.0, fy: 500.0, cx: 319.5, cy: 239.5 };
        let c = ColmapCamera::pinhole(&k, 640, 480);
        assert_eq!(c.params, vec![500.0, 500.0, 320.0, 240.0]);
        assert_eq!(c.intrinsics().0, k);
        let simple = ColmapCamera { model: CameraModel::SimpleRadial, width: 10, height: 10, params: vec![100.0, 5.0, 5.0, 0.01] };
        let (ki, dist) = simple.intrinsics();
        assert_eq!((ki.fx, ki.fy, ki.cx, ki.cy, dist.k1), (100.0, 100.0, 4.5, 4.5, 0.01));
    }

    #[test]
    fn errors_name_line_and_field() {
        let err = parse_cameras_txt("# c\n1 PINHOLE 640 480 500 500 320\n", "cameras.txt").unwrap_err().to_string();
        assert!(err.contains("cameras.txt:2") && err.contains("PARAMS[3]"), "{err}");
        let err = parse_cameras_txt("1 FISHEYE 640 480 1\n", "cameras.txt").unwrap_err().to_string();
        assert!(err.contains("MODEL"), "{err}");
        let err = parse_images_txt("1 0 0 0 0 0 0 0 1 a.png\n\n", "images.txt").unwrap_err().to_string();
        assert!(err.contains("zero quaternion"), "{err}");
        let err = parse_images_txt("1 1 0 0 0 nan 0 0 1 a.png\n\n", "images.txt").unwrap_err().to_string();
        assert!(err.contains("`TX`"), "{err}");
        let err = parse_points3d_txt("1 0 0 0 1 2 3 0.1 5\n", "points3D.txt").unwrap_err().to_string();
        assert!(err.contains("TRACK"), "{err}");
        let m = model();
        let err = ColmapModel::from_text("", &m.images_txt(), "").unwrap_err().to_string();
        assert!(err.contains("missing camera 1"), "{err}");
    }
}
