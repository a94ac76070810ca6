//! Middlebury multi-view stereo calibrations (`*_par.txt`): one line per image with its `K`,
//! `R` and `t` (the projection is `K [R t]`, world to camera), as in the temple and dino rings.

use dynview_core::{Intrinsics, Rigid3};

use crate::error::{ImportError, invalid};
use crate::poses::{CameraPoses, EventPoses, FramePose};

/// Tolerance on `R R^T = I` and `det R = 1` for rotations read from text.
const ROTATION_TOLERANCE: f64 = 1e-6;

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
pub fn parse_middlebury_par(text: &str, file: &str) -> Result<Vec<ParCamera>, ImportError> {
    const FIELDS: usize = 22;
    const FIELD_NAMES: [&str; FIELDS] = [
        "name", "k11", "k12", "k13", "k21", "k22", "k23", "k31", "k32", "k33", "r11", "r12", "r13", "r21", "r22", "r23", "r31", "r32",
        "r33", "t1", "t2", "t3",
    ];
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let (_, count_line) = lines.next().ok_or_else(|| invalid!("{file}: empty"))?;
    let count: usize = count_line.trim().parse().ok().ok_or_else(|| invalid!("{file}:1: field `count`: not a number: {count_line:?}"))?;
    let mut cameras = Vec::with_capacity(count.min(10_000));
    for (index, line) in lines {
        let at = || format!("{file}:{}", index + 1);
        let tokens: Vec<&str> = line.split_whitespace().collect();
        if tokens.len() != FIELDS {
            return Err(invalid!("{}: expected {FIELDS} fields (name, K, R, t), found {}", at(), tokens.len()));
        }
        let mut v = [0.0; FIELDS];
        for k in 1..FIELDS {
            v[k] = tokens[k]
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| invalid!("{}: field `{}`: not a finite number: {:?}", at(), FIELD_NAMES[k], tokens[k]))?;
        }
        let [k11, k12, k13, k21, k22, k23, k31, k32, k33] = [v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9]];
        if k21 != 0.0 || k31 != 0.0 || k32 != 0.0 || k33 != 1.0 || k12.abs() > 1e-9 * k11.abs() {
            return Err(invalid!("{}: field `K`: expected [[fx 0 cx] [0 fy cy] [0 0 1]], found {:?}", at(), &v[1..10]));
        }
        let intrinsics = Intrinsics { fx: k11, fy: k22, cx: k13, cy: k23 };
        if !intrinsics.is_valid() {
            return Err(invalid!("{}: field `K`: focal lengths must be positive", at()));
        }
        let rows = [[v[10], v[11], v[12]], [v[13], v[14], v[15]], [v[16], v[17], v[18]]];
        let camera_from_world = Rigid3::from_rotation_rows(rows, [v[19], v[20], v[21]]);
        if !camera_from_world.is_proper_rigid(ROTATION_TOLERANCE) {
            return Err(invalid!("{}: field `R`: not a rotation (orthonormal with determinant +1)", at()));
        }
        cameras.push(ParCamera { name: tokens[0].to_owned(), intrinsics, camera_from_world });
    }
    if cameras.len() != count {
        return Err(invalid!("{file}: the first line announces {count} images, found {}", cameras.len()));
    }
    Ok(cameras)
}

/// The images of a calibration as event poses: one camera per image, named by the image's file
/// stem, with one frame (the image file) at `size_px(name)`, the image's width and height. The
/// poses are checked as `poses.json` is.
pub fn event_poses(cameras: &[ParCamera], size_px: impl Fn(&str) -> Result<(u32, u32), ImportError>) -> Result<EventPoses, ImportError> {
    let mut event = EventPoses { cameras: Vec::with_capacity(cameras.len()) };
    for camera in cameras {
        let (width, height) = size_px(&camera.name)?;
        let stem = camera.name.rsplit_once('.').map_or(camera.name.as_str(), |(stem, _)| stem);
        event.cameras.push(CameraPoses {
            name: stem.to_owned(),
            width,
            height,
            intrinsics: camera.intrinsics,
            distortion: [0.0; 4],
            frames: vec![FramePose { file: camera.name.clone(), camera_from_world: Some(camera.camera_from_world.into()) }],
        });
    }
    event.validate()?;
    Ok(event)
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;

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
    fn the_temple_ring_becomes_sixteen_one_frame_cameras() {
        let cameras = parse_middlebury_par(TEMPLE_PAR, "templeSR_par.txt").unwrap();
        let event = event_poses(&cameras, |_| Ok((640, 480))).unwrap();
        assert_eq!(event.cameras.len(), 16);
        assert_eq!(event.cameras[0].name, "templeSR0001");
        assert_eq!(event.cameras[0].frames[0].file, "templeSR0001.png");
        assert_eq!(event.cameras[0].frames[0].camera_from_world, Some(cameras[0].camera_from_world.into()));
        let err = event_poses(&cameras, |_| Ok((0, 480))).unwrap_err().to_string();
        assert!(err.contains("width"), "{err}");
    }
}
