//! Qualisys calibrations (`.qca.txt`, XML) as OpenCV cameras, converted exactly as the
//! Pose2Sim project does it (see `../shared/data/README.md`):
//!
//! - `Rq` = the 3x3 of `r11..r33` read row by row, then transposed; `Tq = (x, y, z) / 1000`
//!   (millimetres to metres);
//! - `R = Rq^T`, `t = -R Tq`;
//! - half a turn about the camera's x axis: `R = diag(1,-1,-1) R`, `t = diag(1,-1,-1) t`;
//! - intrinsics: `fx = focalLengthU / 64`, `fy = focalLengthV / 64`,
//!   `cx = centerPointU / 64 - fov_video.left`, `cy = centerPointV / 64 - fov_video.top`
//!   (taken as dynview's principal point, pixel centres at integers); the image is the
//!   `fov_video` rectangle (`right - left + 1` by `bottom - top + 1`);
//! - distortion: OpenCV `k1, k2, p1, p2` = `radialDistortion1`, `radialDistortion2`,
//!   `tangentalDistortion1`, `tangentalDistortion2`, each divided by 64 as Pose2Sim does
//!   (`radialDistortion3` is zero in the files we have and OpenCV's 4-term model has no k3).
//!
//! The XML is read by a small tag scanner: the file is machine-written, flat and small.

use dynview_core::{Intrinsics, Rigid3};
use glam::{DMat3, DVec3};

use crate::error::{ImportError, invalid};
use crate::poses::{CameraPoses, EventPoses, FramePose};

/// Qualisys stores focal lengths and principal points in 1/64 pixel.
const SUBPIXELS_PER_PIXEL: f64 = 64.0;
/// Millimetres per metre.
const MM_PER_M: f64 = 1000.0;

/// One camera of a Qualisys calibration, in OpenCV conventions.
#[derive(Clone, Debug, PartialEq)]
pub struct QualisysCamera {
    /// The camera's `serial` attribute (Pose2Sim names them `cam01`, ...).
    pub serial: String,
    /// Pinhole intrinsics in pixels.
    pub intrinsics: Intrinsics,
    /// OpenCV distortion `k1, k2, p1, p2` (see the module documentation).
    pub distortion: [f64; 4],
    /// World-to-camera pose, metres.
    pub camera_from_world: Rigid3,
    /// Video width in pixels.
    pub width_px: u32,
    /// Video height in pixels.
    pub height_px: u32,
}

/// An XML start, empty-element or end tag.
#[derive(Debug)]
struct Tag {
    name: String,
    attributes: Vec<(String, String)>,
    /// `</name>`.
    end: bool,
}

impl Tag {
    fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes.iter().find(|(k, _)| k == name).map(|(_, v)| v.as_str())
    }
}

/// The tags of an XML document in order (declarations, comments and text skipped).
fn scan_tags(text: &str, file: &str) -> Result<Vec<Tag>, ImportError> {
    let mut tags = Vec::new();
    let mut rest = text;
    while let Some(open) = rest.find('<') {
        rest = &rest[open..];
        let line = || text[..text.len() - rest.len()].lines().count().max(1);
        let skip_to = |end: &str| rest.find(end).map(|i| i + end.len()).ok_or_else(|| invalid!("{file}:{}: unterminated {end:?}", line()));
        if rest.starts_with("<!--") {
            rest = &rest[skip_to("-->")?..];
            continue;
        }
        if rest.starts_with("<?") || rest.starts_with("<!") {
            rest = &rest[skip_to(">")?..];
            continue;
        }
        let close = skip_to(">")?;
        let body = rest[1..close - 1].trim();
        let tag_line = line();
        rest = &rest[close..];
        let (end, body) = match body.strip_prefix('/') {
            Some(b) => (true, b),
            None => (false, body.strip_suffix('/').unwrap_or(body)),
        };
        let name_len = body.find(char::is_whitespace).unwrap_or(body.len());
        let name = body[..name_len].to_owned();
        let mut attrs = body[name_len..].trim_start();
        let mut attributes = Vec::new();
        while !attrs.is_empty() {
            let eq = attrs.find('=').ok_or_else(|| invalid!("{file}:{tag_line}: <{name}>: attribute without a value: {attrs:?}"))?;
            let key = attrs[..eq].trim().to_owned();
            let after = attrs[eq + 1..].trim_start();
            let quote = after.chars().next().filter(|c| *c == '"' || *c == '\'');
            let quote = quote.ok_or_else(|| invalid!("{file}:{tag_line}: <{name}> attribute `{key}`: value not quoted"))?;
            let value_end =
                after[1..].find(quote).ok_or_else(|| invalid!("{file}:{tag_line}: <{name}> attribute `{key}`: unterminated"))?;
            attributes.push((key, unescape(&after[1..1 + value_end])));
            attrs = after[value_end + 2..].trim_start();
        }
        tags.push(Tag { name, attributes, end });
    }
    Ok(tags)
}

/// Replaces XML's predefined entities.
fn unescape(value: &str) -> String {
    value.replace("&lt;", "<").replace("&gt;", ">").replace("&quot;", "\"").replace("&apos;", "'").replace("&amp;", "&")
}

/// The `<transform>`, `<intrinsic>` and `<fov_video>` tags of one `<camera>`.
#[derive(Default)]
struct CameraTags<'a> {
    serial: String,
    transform: Option<&'a Tag>,
    intrinsic: Option<&'a Tag>,
    fov_video: Option<&'a Tag>,
}

/// Parses a Qualisys calibration into OpenCV cameras (see the module documentation). `file`
/// names the source in errors.
pub fn parse_qualisys_calibration(text: &str, file: &str) -> Result<Vec<QualisysCamera>, ImportError> {
    let tags = scan_tags(text, file)?;
    let mut cameras = Vec::new();
    let mut current: Option<CameraTags> = None;
    for tag in &tags {
        match (tag.name.as_str(), tag.end, current.as_mut()) {
            ("camera", false, None) => {
                let serial = tag.attribute("serial").ok_or_else(|| invalid!("{file}: <camera> without `serial`"))?;
                current = Some(CameraTags { serial: serial.to_owned(), ..CameraTags::default() });
            }
            ("camera", false, Some(c)) => return Err(invalid!("{file}: camera {}: <camera> inside <camera>", c.serial)),
            ("camera", true, Some(_)) => {
                if let Some(done) = current.take() {
                    cameras.push(camera_from_tags(&done, file)?);
                }
            }
            ("transform", false, Some(c)) => c.transform = Some(tag),
            ("intrinsic", false, Some(c)) => c.intrinsic = Some(tag),
            ("fov_video", false, Some(c)) => c.fov_video = Some(tag),
            _ => {}
        }
    }
    if let Some(c) = current {
        return Err(invalid!("{file}: camera {}: missing </camera>", c.serial));
    }
    if cameras.is_empty() {
        return Err(invalid!("{file}: no <camera> found"));
    }
    Ok(cameras)
}

fn camera_from_tags(tags: &CameraTags, file: &str) -> Result<QualisysCamera, ImportError> {
    let serial = &tags.serial;
    let number = |tag: Option<&Tag>, tag_name: &str, key: &str| -> Result<f64, ImportError> {
        let tag = tag.ok_or_else(|| invalid!("{file}: camera {serial}: missing <{tag_name}>"))?;
        let value = tag.attribute(key).ok_or_else(|| invalid!("{file}: camera {serial}: <{tag_name}> lacks `{key}`"))?;
        value
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| invalid!("{file}: camera {serial}: <{tag_name}> `{key}`: not a finite number: {value:?}"))
    };
    let transform = |key: &str| number(tags.transform, "transform", key);
    let r = |row: usize, col: usize| transform(&format!("r{row}{col}"));
    // The 3x3 read row by row (glam builds from columns, hence the transpose), then transposed.
    let read_row_by_row = DMat3::from_cols(
        DVec3::new(r(1, 1)?, r(1, 2)?, r(1, 3)?),
        DVec3::new(r(2, 1)?, r(2, 2)?, r(2, 3)?),
        DVec3::new(r(3, 1)?, r(3, 2)?, r(3, 3)?),
    )
    .transpose();
    let rq = read_row_by_row.transpose();
    let tq = DVec3::new(transform("x")?, transform("y")?, transform("z")?) / MM_PER_M;
    let rotation = rq.transpose();
    let translation = -(rotation * tq);
    let half_turn_about_x = DMat3::from_diagonal(DVec3::new(1.0, -1.0, -1.0));
    let camera_from_world = Rigid3::new(half_turn_about_x * rotation, half_turn_about_x * translation);
    if !camera_from_world.is_proper_rigid(1e-6) {
        return Err(invalid!("{file}: camera {serial}: <transform> r11..r33 is not a rotation"));
    }

    let fov = |key: &str| number(tags.fov_video, "fov_video", key);
    let (left, top, right, bottom) = (fov("left")?, fov("top")?, fov("right")?, fov("bottom")?);
    let intrinsic = |key: &str| number(tags.intrinsic, "intrinsic", key);
    let intrinsics = Intrinsics {
        fx: intrinsic("focalLengthU")? / SUBPIXELS_PER_PIXEL,
        fy: intrinsic("focalLengthV")? / SUBPIXELS_PER_PIXEL,
        cx: intrinsic("centerPointU")? / SUBPIXELS_PER_PIXEL - left,
        cy: intrinsic("centerPointV")? / SUBPIXELS_PER_PIXEL - top,
    };
    if !intrinsics.is_valid() {
        return Err(invalid!("{file}: camera {serial}: <intrinsic> focal lengths must be positive"));
    }
    let size = |lo: f64, hi: f64, what: &str| -> Result<u32, ImportError> {
        let pixels = hi - lo + 1.0;
        if pixels < 1.0 || pixels.fract() != 0.0 || pixels > f64::from(u32::MAX) {
            return Err(invalid!("{file}: camera {serial}: <fov_video> gives a {what} of {pixels} pixels"));
        }
        Ok(pixels as u32)
    };
    let distortion = [
        intrinsic("radialDistortion1")? / SUBPIXELS_PER_PIXEL,
        intrinsic("radialDistortion2")? / SUBPIXELS_PER_PIXEL,
        intrinsic("tangentalDistortion1")? / SUBPIXELS_PER_PIXEL,
        intrinsic("tangentalDistortion2")? / SUBPIXELS_PER_PIXEL,
    ];
    Ok(QualisysCamera {
        serial: serial.clone(),
        intrinsics,
        distortion,
        camera_from_world,
        width_px: size(left, right, "width")?,
        height_px: size(top, bottom, "height")?,
    })
}

/// The file name given to the single frame of each camera in [`event_poses`]: a calibrated rig
/// has one pose per camera, which `dynview prep --poses` applies to every frame.
pub const RIG_FRAME_FILE: &str = "00000.jpg";

/// The cameras of a calibration as event poses: one camera per calibrated camera (named by its
/// serial), keeping those in `keep` when given, each with one frame ([`RIG_FRAME_FILE`]) whose
/// pose holds for every frame of a fixed rig.
pub fn event_poses(cameras: &[QualisysCamera], keep: Option<&[&str]>) -> EventPoses {
    EventPoses {
        cameras: cameras
            .iter()
            .filter(|c| keep.is_none_or(|k| k.contains(&c.serial.as_str())))
            .map(|c| CameraPoses {
                name: c.serial.clone(),
                width: c.width_px,
                height: c.height_px,
                intrinsics: c.intrinsics,
                distortion: c.distortion,
                frames: vec![FramePose { file: RIG_FRAME_FILE.into(), camera_from_world: Some(c.camera_from_world.into()) }],
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CALIBRATION: &str = include_str!("../../../tests/data/pose2sim-multiperson/Calib.qca.txt");

    /// The point closest (least squares) to every camera's optical axis.
    fn optical_axes_meeting_point(cameras: &[QualisysCamera]) -> DVec3 {
        let (mut a, mut b) = (DMat3::ZERO, DVec3::ZERO);
        for c in cameras {
            let center = c.camera_from_world.camera_center_world();
            let axis = c.camera_from_world.rotation.transpose() * DVec3::Z;
            let off_axis = DMat3::IDENTITY - DMat3::from_cols(axis * axis.x, axis * axis.y, axis * axis.z);
            a += off_axis;
            b += off_axis * center;
        }
        a.inverse() * b
    }

    #[test]
    fn converts_the_pose2sim_calibration() {
        let cameras = parse_qualisys_calibration(CALIBRATION, "Calib.qca.txt").unwrap();
        let serials: Vec<&str> = cameras.iter().map(|c| c.serial.as_str()).collect();
        assert_eq!(serials, ["cam01", "cam02", "cam03", "cam04"]);
        let c = &cameras[0];
        assert_eq!((c.width_px, c.height_px), (1088, 1920));
        assert!((c.intrinsics.fx - 107599.671875 / 64.0).abs() < 1e-9);
        assert!((c.intrinsics.cy - 60680.792969 / 64.0).abs() < 1e-9);
        assert_eq!(c.distortion, [-0.046183 / 64.0, 0.139983 / 64.0, 0.000608 / 64.0, 0.00069 / 64.0]);
        // R = diag(1,-1,-1) Rq^T with Rq the transpose of the rows read: R's rows are the file's
        // rows, the last two negated; the centre is Tq in metres.
        let rows = c.camera_from_world.rotation_rows();
        assert_eq!(rows[0], [0.5536380477336265, 0.8046719867383512, 0.2144479094331626]);
        assert_eq!(rows[1], [0.4345300743838753, -0.05946489349975602, -0.8986921279821063]);
        let center = c.camera_from_world.camera_center_world();
        assert!((center - DVec3::new(1.4602323709212087, -1.9091590482454608, 1.8965058524092062)).length() < 1e-12);
    }

    #[test]
    fn optical_axes_meet_in_front_of_every_camera_near_the_image_centres() {
        // The README's check: the axes meet about 3.4 m in front of every camera, at a point
        // that projects near each image centre (measured: 3.32 to 3.76 m, 20 to 81 px off).
        let cameras = parse_qualisys_calibration(CALIBRATION, "Calib.qca.txt").unwrap();
        let meeting = optical_axes_meeting_point(&cameras);
        for c in &cameras {
            let in_camera = c.camera_from_world.transform_point(meeting);
            assert!((3.2..3.9).contains(&in_camera.z), "{}: the axes meet {:.2} m in front", c.serial, in_camera.z);
            let pixel = c.intrinsics.project(in_camera).unwrap();
            let centre = glam::DVec2::new(f64::from(c.width_px) - 1.0, f64::from(c.height_px) - 1.0) * 0.5;
            assert!((pixel - centre).length() < 0.05 * f64::from(c.height_px), "{}: projects at {pixel}, centre {centre}", c.serial);
        }
    }

    #[test]
    fn bad_calibrations_name_the_camera_and_field() {
        let missing = CALIBRATION.replacen("r22=", "q22=", 1);
        let err = parse_qualisys_calibration(&missing, "c.qca.txt").unwrap_err().to_string();
        assert!(err.contains("camera cam01") && err.contains("`r22`"), "{err}");
        let not_number = CALIBRATION.replacen("focalLengthU=\"107599.671875\"", "focalLengthU=\"abc\"", 1);
        let err = parse_qualisys_calibration(&not_number, "c.qca.txt").unwrap_err().to_string();
        assert!(err.contains("focalLengthU") && err.contains("not a finite number"), "{err}");
        let err = parse_qualisys_calibration("<calibration><cameras/></calibration>", "c.qca.txt").unwrap_err().to_string();
        assert!(err.contains("no <camera>"), "{err}");
        let err = parse_qualisys_calibration("<camera serial=\"a\"><transform r11=1/></camera>", "c.qca.txt").unwrap_err().to_string();
        assert!(err.contains("not quoted"), "{err}");
    }

    #[test]
    fn event_poses_validate_and_keep_the_chosen_cameras() {
        let cameras = parse_qualisys_calibration(CALIBRATION, "Calib.qca.txt").unwrap();
        let all = event_poses(&cameras, None);
        all.validate().unwrap();
        assert_eq!(all.cameras.len(), 4);
        assert_eq!((all.cameras[0].width, all.cameras[0].height), (1088, 1920));
        assert!(all.cameras.iter().all(|c| c.frames.len() == 1 && c.distortion[0] < 0.0));
        let three = event_poses(&cameras, Some(&["cam01", "cam03", "cam04"]));
        let names: Vec<&str> = three.cameras.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["cam01", "cam03", "cam04"]);
        let round_trip = EventPoses::from_json_bytes(three.to_json_string().as_bytes(), "poses.json").unwrap();
        assert_eq!(round_trip.cameras[2].frames[0].camera_from_world, Some(cameras[3].camera_from_world.into()));
    }
}
