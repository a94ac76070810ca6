//! COLMAP's binary form: `cameras.bin`, `images.bin`, `points3D.bin`, little-endian, laid out as
//! COLMAP 3.8 writes them (`Reconstruction::Write*Binary` in `src/base/reconstruction.cc`):
//!
//! - `cameras.bin`: `u64` count; per camera `u32` camera_id, `i32` model_id, `u64` width,
//!   `u64` height, `f64` params (as many as the model has);
//! - `images.bin`: `u64` count; per image `u32` image_id, `f64` qvec `[w, x, y, z]`, `f64` tvec
//!   `[x, y, z]`, `u32` camera_id, the name NUL-terminated, `u64` num_points2D, per point `f64`
//!   x, `f64` y, `u64` point3D_id (`u64::MAX`: none);
//! - `points3D.bin`: `u64` count; per point `u64` point3D_id, `f64` xyz, `u8` rgb, `f64` error,
//!   `u64` track_length, per element `u32` image_id, `u32` point2D_idx.
//!
//! Readers treat the bytes as hostile: every count is checked against the bytes left in the
//! file before anything is allocated, names are capped at [`MAX_IMAGE_NAME_BYTES`], and an error
//! names the file, the entry and the field (`images.bin: image 3 (id 4): field `name`: ...`).

use std::collections::BTreeMap;
use std::fmt;

use super::{CameraModel, ColmapCamera, ColmapError, ColmapImage, ColmapModel, ColmapPoint3D, MAX_ENTRIES, Point2D};
use dynview_core::camera::Rigid3;
use dynview_core::rotation::{matrix_from_quaternion_wxyz, quaternion_wxyz_from_matrix};

/// Longest image name accepted from `images.bin`, in bytes (without the NUL).
pub const MAX_IMAGE_NAME_BYTES: usize = 4096;

/// The `point3D_id` COLMAP writes for a 2D point without a 3D point (`kInvalidPoint3DId`).
const NO_POINT3D_ID: u64 = u64::MAX;

/// Size of the count every file starts with.
const COUNT_BYTES: usize = 8;
/// Smallest camera: ids, size and the 3 parameters of `SIMPLE_PINHOLE`.
const MIN_CAMERA_BYTES: usize = 4 + 4 + 8 + 8 + 3 * 8;
/// Smallest image: id, qvec, tvec, camera id, an empty name's NUL and `num_points2D`.
const MIN_IMAGE_BYTES: usize = 4 + 4 * 8 + 3 * 8 + 4 + 1 + 8;
/// One 2D point: x, y and the 3D point id.
const POINT2D_BYTES: usize = 8 + 8 + 8;
/// Smallest 3D point: id, xyz, rgb, error and an empty track's length.
const MIN_POINT3D_BYTES: usize = 8 + 3 * 8 + 3 + 8 + 8;
/// One track element: image id and 2D point index.
const TRACK_ELEMENT_BYTES: usize = 4 + 4;

/// Which entry of a file a field belongs to, formatted only when an error is reported.
#[derive(Clone, Copy, Debug)]
struct Entry {
    kind: &'static str,
    index: Option<usize>,
    id: Option<u64>,
}

impl Entry {
    const HEADER: Self = Self { kind: "header", index: None, id: None };

    fn nth(kind: &'static str, index: usize) -> Self {
        Self { kind, index: Some(index), id: None }
    }
}

impl fmt::Display for Entry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.kind)?;
        if let Some(index) = self.index {
            write!(f, " {index}")?;
        }
        if let Some(id) = self.id {
            write!(f, " (id {id})")?;
        }
        Ok(())
    }
}

/// A cursor over a file's bytes that turns every short read into an error naming the field.
struct Reader<'a> {
    file: &'a str,
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn new(file: &'a str, bytes: &'a [u8]) -> Self {
        Self { file, bytes, pos: 0 }
    }

    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    fn err(&self, entry: Entry, field: impl Into<String>, problem: impl Into<String>) -> ColmapError {
        ColmapError::Binary { file: self.file.to_owned(), entry: entry.to_string(), field: field.into(), problem: problem.into() }
    }

    fn take<const N: usize>(&mut self, entry: Entry, field: &str) -> Result<[u8; N], ColmapError> {
        let Some(chunk) = self.bytes.get(self.pos..self.pos + N) else {
            return Err(self.err(
                entry,
                field,
                format!("file truncated: needs {N} bytes at offset {}, the file has {}", self.pos, self.bytes.len()),
            ));
        };
        self.pos += N;
        let mut out = [0u8; N];
        out.copy_from_slice(chunk);
        Ok(out)
    }

    fn u8(&mut self, entry: Entry, field: &str) -> Result<u8, ColmapError> {
        Ok(self.take::<1>(entry, field)?[0])
    }

    fn u32(&mut self, entry: Entry, field: &str) -> Result<u32, ColmapError> {
        Ok(u32::from_le_bytes(self.take(entry, field)?))
    }

    fn i32(&mut self, entry: Entry, field: &str) -> Result<i32, ColmapError> {
        Ok(i32::from_le_bytes(self.take(entry, field)?))
    }

    fn u64(&mut self, entry: Entry, field: &str) -> Result<u64, ColmapError> {
        Ok(u64::from_le_bytes(self.take(entry, field)?))
    }

    fn f64(&mut self, entry: Entry, field: &str) -> Result<f64, ColmapError> {
        Ok(f64::from_le_bytes(self.take(entry, field)?))
    }

    /// `N` finite `f64`s; the error names the element, e.g. `tvec[2]`.
    fn finite_f64s<const N: usize>(&mut self, entry: Entry, field: &str) -> Result<[f64; N], ColmapError> {
        let mut out = [0.0; N];
        for (k, value) in out.iter_mut().enumerate() {
            *value = self.f64(entry, field)?;
            if !value.is_finite() {
                return Err(self.err(entry, format!("{field}[{k}]"), format!("not finite ({value})")));
            }
        }
        Ok(out)
    }

    /// A `u64` count of items at least `min_bytes_each` long, checked against the bytes left
    /// in the file (and [`MAX_ENTRIES`]) so that no hostile count can make us allocate.
    fn count(&mut self, entry: Entry, field: &str, min_bytes_each: usize) -> Result<usize, ColmapError> {
        let count = self.u64(entry, field)?;
        let fits = (self.remaining() / min_bytes_each) as u64;
        if count > fits {
            return Err(self.err(
                entry,
                field,
                format!(
                    "{count} entries of at least {min_bytes_each} bytes cannot fit in the {} bytes left (file truncated or corrupt)",
                    self.remaining()
                ),
            ));
        }
        if count > MAX_ENTRIES as u64 {
            return Err(self.err(entry, field, format!("{count} entries exceeds the limit of {MAX_ENTRIES}")));
        }
        Ok(count as usize)
    }

    /// A NUL-terminated image name: UTF-8, 1 to [`MAX_IMAGE_NAME_BYTES`] bytes, without
    /// whitespace or control characters (which `images.txt` could not hold).
    fn name(&mut self, entry: Entry) -> Result<String, ColmapError> {
        const FIELD: &str = "name";
        let window = &self.bytes[self.pos..self.bytes.len().min(self.pos + MAX_IMAGE_NAME_BYTES + 1)];
        let Some(len) = window.iter().position(|&b| b == 0) else {
            let problem = if window.len() > MAX_IMAGE_NAME_BYTES {
                format!("no NUL within {MAX_IMAGE_NAME_BYTES} bytes (name too long or file corrupt)")
            } else {
                "not NUL-terminated before the end of the file (file truncated)".to_owned()
            };
            return Err(self.err(entry, FIELD, problem));
        };
        let name = std::str::from_utf8(&window[..len]).map_err(|e| self.err(entry, FIELD, format!("not UTF-8: {e}")))?.to_owned();
        if name.is_empty() {
            return Err(self.err(entry, FIELD, "empty"));
        }
        if name.chars().any(|c| c.is_whitespace() || c.is_control()) {
            return Err(self.err(entry, FIELD, format!("{name:?} contains whitespace or control characters")));
        }
        self.pos += len + 1;
        Ok(name)
    }

    /// Checks that the whole file was read.
    fn finish(self) -> Result<(), ColmapError> {
        if self.remaining() > 0 {
            return Err(self.err(
                Entry::HEADER,
                "(end of file)",
                format!("{} bytes left after the last entry (count too small or file corrupt)", self.remaining()),
            ));
        }
        Ok(())
    }
}

/// Inserts `value` under `key`, refusing a duplicate id.
fn insert_unique<K: Ord + fmt::Display + Copy, V>(
    map: &mut BTreeMap<K, V>,
    key: K,
    value: V,
    r: &Reader,
    entry: Entry,
    field: &str,
) -> Result<(), ColmapError> {
    if map.insert(key, value).is_some() {
        return Err(r.err(entry, field, format!("duplicate id {key}")));
    }
    Ok(())
}

/// Parses `cameras.bin`. `file` names the file in errors.
pub fn parse_cameras_bin(bytes: &[u8], file: &str) -> Result<BTreeMap<u32, ColmapCamera>, ColmapError> {
    let mut r = Reader::new(file, bytes);
    let count = r.count(Entry::HEADER, "num_cameras", MIN_CAMERA_BYTES)?;
    let mut cameras = BTreeMap::new();
    for i in 0..count {
        let mut entry = Entry::nth("camera", i);
        let id = r.u32(entry, "camera_id")?;
        entry.id = Some(id.into());
        let model_id = r.i32(entry, "model_id")?;
        let model = CameraModel::from_id(model_id).ok_or_else(|| {
            let known: Vec<String> = CameraModel::ALL.iter().map(|m| format!("{} {}", m.id(), m.name())).collect();
            r.err(entry, "model_id", format!("unsupported camera model {model_id} (dynview reads {})", known.join(", ")))
        })?;
        let mut side = |field: &str| -> Result<u32, ColmapError> {
            let value = r.u64(entry, field)?;
            u32::try_from(value).map_err(|_| r.err(entry, field, format!("{value} pixels is out of range")))
        };
        let (width, height) = (side("width")?, side("height")?);
        let mut params = Vec::with_capacity(model.param_count());
        for k in 0..model.param_count() {
            let value = r.f64(entry, "params")?;
            if !value.is_finite() {
                return Err(r.err(entry, format!("params[{k}]"), format!("not finite ({value})")));
            }
            params.push(value);
        }
        insert_unique(&mut cameras, id, ColmapCamera { model, width, height, params }, &r, entry, "camera_id")?;
    }
    r.finish()?;
    Ok(cameras)
}

/// Parses `images.bin`. `file` names the file in errors.
pub fn parse_images_bin(bytes: &[u8], file: &str) -> Result<BTreeMap<u32, ColmapImage>, ColmapError> {
    let mut r = Reader::new(file, bytes);
    let count = r.count(Entry::HEADER, "num_reg_images", MIN_IMAGE_BYTES)?;
    let mut images = BTreeMap::new();
    for i in 0..count {
        let mut entry = Entry::nth("image", i);
        let id = r.u32(entry, "image_id")?;
        entry.id = Some(id.into());
        let qvec: [f64; 4] = r.finite_f64s(entry, "qvec")?;
        let tvec: [f64; 3] = r.finite_f64s(entry, "tvec")?;
        let rotation = matrix_from_quaternion_wxyz(qvec).ok_or_else(|| r.err(entry, "qvec", "zero quaternion"))?;
        let camera_id = r.u32(entry, "camera_id")?;
        let name = r.name(entry)?;
        let point_count = r.count(entry, "num_points2D", POINT2D_BYTES)?;
        let mut points2d = Vec::with_capacity(point_count);
        for k in 0..point_count {
            let xy = [r.f64(entry, "points2D")?, r.f64(entry, "points2D")?];
            if xy.iter().any(|v| !v.is_finite()) {
                return Err(r.err(entry, format!("points2D[{k}].xy"), format!("not finite ({xy:?})")));
            }
            let point3d_id = r.u64(entry, "points2D")?;
            points2d.push(Point2D { xy, point3d_id: (point3d_id != NO_POINT3D_ID).then_some(point3d_id) });
        }
        let image = ColmapImage { camera_id, camera_from_world: Rigid3::new(rotation, glam::DVec3::from_array(tvec)), name, points2d };
        insert_unique(&mut images, id, image, &r, entry, "image_id")?;
    }
    r.finish()?;
    Ok(images)
}

/// Parses `points3D.bin`. `file` names the file in errors.
pub fn parse_points3d_bin(bytes: &[u8], file: &str) -> Result<BTreeMap<u64, ColmapPoint3D>, ColmapError> {
    let mut r = Reader::new(file, bytes);
    let count = r.count(Entry::HEADER, "num_points3D", MIN_POINT3D_BYTES)?;
    let mut points = BTreeMap::new();
    for i in 0..count {
        let mut entry = Entry::nth("point3D", i);
        let id = r.u64(entry, "point3D_id")?;
        entry.id = Some(id);
        let xyz: [f64; 3] = r.finite_f64s(entry, "xyz")?;
        let rgb = [r.u8(entry, "rgb")?, r.u8(entry, "rgb")?, r.u8(entry, "rgb")?];
        let error = r.f64(entry, "error")?;
        let track_length = r.count(entry, "track_length", TRACK_ELEMENT_BYTES)?;
        let mut track = Vec::with_capacity(track_length);
        for _ in 0..track_length {
            track.push((r.u32(entry, "track")?, r.u32(entry, "track")?));
        }
        insert_unique(&mut points, id, ColmapPoint3D { xyz, rgb, error, track }, &r, entry, "point3D_id")?;
    }
    r.finish()?;
    Ok(points)
}

fn put_u64(out: &mut Vec<u8>, value: u64) {
    out.extend_from_slice(&value.to_le_bytes());
}

fn put_f64s(out: &mut Vec<u8>, values: &[f64]) {
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

impl ColmapModel {
    /// Parses the three binary files and checks that images name existing cameras.
    pub fn from_binary(cameras_bin: &[u8], images_bin: &[u8], points3d_bin: &[u8]) -> Result<Self, ColmapError> {
        Self::from_binary_named([cameras_bin, images_bin, points3d_bin], ["cameras.bin", "images.bin", "points3D.bin"])
    }

    /// [`ColmapModel::from_binary`] with the names (or paths) errors give the three files.
    pub(crate) fn from_binary_named(bytes: [&[u8]; 3], files: [&str; 3]) -> Result<Self, ColmapError> {
        let model = Self {
            cameras: parse_cameras_bin(bytes[0], files[0])?,
            images: parse_images_bin(bytes[1], files[1])?,
            points3d: parse_points3d_bin(bytes[2], files[2])?,
        };
        model.check_references(files[1])?;
        Ok(model)
    }

    /// `cameras.bin` contents.
    pub fn cameras_bin(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(COUNT_BYTES + self.cameras.len() * (MIN_CAMERA_BYTES + 5 * 8));
        put_u64(&mut out, self.cameras.len() as u64);
        for (id, camera) in &self.cameras {
            out.extend_from_slice(&id.to_le_bytes());
            out.extend_from_slice(&camera.model.id().to_le_bytes());
            put_u64(&mut out, camera.width.into());
            put_u64(&mut out, camera.height.into());
            put_f64s(&mut out, &camera.params);
        }
        out
    }

    /// `images.bin` contents. Names are written as they are (they must not contain NUL).
    pub fn images_bin(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(COUNT_BYTES + self.images.len() * (MIN_IMAGE_BYTES + 32));
        put_u64(&mut out, self.images.len() as u64);
        for (id, image) in &self.images {
            out.extend_from_slice(&id.to_le_bytes());
            put_f64s(&mut out, &quaternion_wxyz_from_matrix(image.camera_from_world.rotation));
            put_f64s(&mut out, &image.camera_from_world.translation.to_array());
            out.extend_from_slice(&image.camera_id.to_le_bytes());
            out.extend_from_slice(image.name.as_bytes());
            out.push(0);
            put_u64(&mut out, image.points2d.len() as u64);
            for point in &image.points2d {
                put_f64s(&mut out, &point.xy);
                put_u64(&mut out, point.point3d_id.unwrap_or(NO_POINT3D_ID));
            }
        }
        out
    }

    /// `points3D.bin` contents.
    pub fn points3d_bin(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(COUNT_BYTES + self.points3d.len() * (MIN_POINT3D_BYTES + 2 * TRACK_ELEMENT_BYTES));
        put_u64(&mut out, self.points3d.len() as u64);
        for (id, point) in &self.points3d {
            put_u64(&mut out, *id);
            put_f64s(&mut out, &point.xyz);
            out.extend_from_slice(&point.rgb);
            put_f64s(&mut out, &[point.error]);
            put_u64(&mut out, point.track.len() as u64);
            for (image_id, point2d_idx) in &point.track {
                out.extend_from_slice(&image_id.to_le_bytes());
                out.extend_from_slice(&point2d_idx.to_le_bytes());
            }
        }
        out
    }
}

#[cfg(test)]
mod tests;
