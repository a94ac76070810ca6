//! Camera placement: input cameras on an arc (60 degrees unless a [`Layout`] says otherwise;
//! optionally hand-held, with a smooth wobble) and a held-out camera that moves between them.

use glam::{DMat3, DVec3};
use rand::{Rng, SeedableRng, rngs::SmallRng};

use dynview_core::rotation::matrix_from_angle_axis;
use dynview_core::{Camera, Intrinsics, Rigid3};

/// Total angle spanned by the input cameras by default.
pub const ARC_DEG: f64 = 60.0;
/// Distance of the input cameras from the arc's centre (m).
pub const ARC_RADIUS_M: f64 = 7.0;
/// Height of the input cameras (m).
pub const CAMERA_HEIGHT_M: f64 = 1.7;
/// Where every camera looks.
pub const LOOK_AT: DVec3 = DVec3::new(0.0, 0.8, -0.8);
/// Vertical field of view of every camera (degrees).
pub const VERTICAL_FOV_DEG: f64 = 42.0;
/// Wobble of hand-held cameras: position amplitude (m).
pub const HANDHELD_POSITION_M: f64 = 0.04;
/// Wobble of hand-held cameras: rotation amplitude (degrees).
pub const HANDHELD_ROTATION_DEG: f64 = 0.8;
/// The held-out camera sweeps this fraction of the input arc.
pub const HELDOUT_SWEEP: f64 = 0.6;

fn eye_on_arc(angle_rad: f64, radius_m: f64, height_m: f64) -> DVec3 {
    DVec3::new(radius_m * angle_rad.sin(), height_m, LOOK_AT.z + radius_m * angle_rad.cos())
}

/// How the input cameras stand and what lenses they have (the SfM tests' other layouts).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Layout {
    /// Total angle spanned by the input cameras (degrees).
    pub arc_deg: f64,
    /// Focal lengths as multiples of the longer image side, from the first camera to the last
    /// (spread evenly); `None`: every camera has a 42-degree vertical field of view.
    pub focal_range: Option<[f64; 2]>,
    /// Offset of the true principal point from the image centre (px); the sign alternates from
    /// camera to camera, so no two neighbours share it.
    pub principal_offset_px: [f64; 2],
    /// How far the input cameras stand above and below [`CAMERA_HEIGHT_M`] (m), alternately from
    /// camera to camera as on a studio's dome (0: all at one height).
    pub height_spread_m: f64,
}

impl Default for Layout {
    fn default() -> Self {
        Self { arc_deg: ARC_DEG, focal_range: None, principal_offset_px: [0.0, 0.0], height_spread_m: 0.0 }
    }
}

impl Layout {
    /// The intrinsics of input camera `i` of `n` at `width` x `height`.
    pub fn intrinsics(&self, i: usize, n: usize, width: u32, height: u32) -> Intrinsics {
        let base = Intrinsics::from_vertical_fov(VERTICAL_FOV_DEG.to_radians(), width, height);
        let focal = self.focal_range.map_or(base.fx, |[first, last]| {
            let s = if n <= 1 { 0.0 } else { i as f64 / (n - 1) as f64 };
            f64::from(width.max(height)) * (first + (last - first) * s)
        });
        let sign = alternate_sign(i);
        Intrinsics {
            fx: focal,
            fy: focal,
            cx: base.cx + sign * self.principal_offset_px[0],
            cy: base.cy + sign * self.principal_offset_px[1],
        }
    }
}

/// +1 for even cameras, -1 for odd ones.
fn alternate_sign(i: usize) -> f64 {
    if i.is_multiple_of(2) { 1.0 } else { -1.0 }
}

/// Angle of input camera `i` of `n` on the default arc (radians), centred on the z axis.
pub fn input_angle_rad(i: usize, n: usize) -> f64 {
    arc_angle_rad(i, n, ARC_DEG)
}

/// Angle of input camera `i` of `n` on an arc of `arc_deg` (radians), centred on the z axis.
fn arc_angle_rad(i: usize, n: usize, arc_deg: f64) -> f64 {
    let half = 0.5 * arc_deg.to_radians();
    if n <= 1 {
        return 0.0;
    }
    -half + 2.0 * half * i as f64 / (n - 1) as f64
}

/// A smooth random signal: a few sines of random frequency (0.3 to 1.7 Hz) and phase.
#[derive(Clone, Debug)]
struct Wobble {
    terms: Vec<(DVec3, f64, f64)>,
}

impl Wobble {
    fn new(rng: &mut SmallRng) -> Self {
        let terms = (0..3)
            .map(|_| {
                let dir = DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
                (dir, rng.random_range(0.3..1.7), rng.random_range(0.0..std::f64::consts::TAU))
            })
            .collect();
        Self { terms }
    }

    /// A vector with components of magnitude up to about 1.
    fn at(&self, t_s: f64) -> DVec3 {
        self.terms.iter().map(|(dir, freq, phase)| *dir * (std::f64::consts::TAU * freq * t_s + phase).sin()).sum::<DVec3>()
            / self.terms.len() as f64
    }
}

/// An input camera.
#[derive(Clone, Debug)]
struct InputCamera {
    /// Its angle on the arc (radians).
    angle_rad: f64,
    /// Its height (m).
    height_m: f64,
    /// Its lens.
    intrinsics: Intrinsics,
    /// Its wobble (position, rotation) when hand-held.
    wobble: Option<(Wobble, Wobble)>,
}

/// The cameras of an event.
#[derive(Clone, Debug)]
pub struct Rig {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    intrinsics: Intrinsics,
    inputs: Vec<InputCamera>,
    duration_s: f64,
    arc_deg: f64,
}

impl Rig {
    /// `n` input cameras; with `handheld`, each gets its own smooth wobble from `seed`.
    /// `duration_s` is the length of the event (the held-out camera sweeps over it).
    pub fn new(n: usize, width: u32, height: u32, handheld: bool, seed: u64, duration_s: f64) -> Self {
        Self::with_layout(n, width, height, handheld, seed, duration_s, &Layout::default())
    }

    /// As [`Rig::new`], the inputs placed and given lenses by `layout` (the held-out camera
    /// keeps the default lens and sweeps the middle of the layout's arc).
    pub fn with_layout(n: usize, width: u32, height: u32, handheld: bool, seed: u64, duration_s: f64, layout: &Layout) -> Self {
        let mut rng = SmallRng::seed_from_u64(seed ^ 0x5EED_CA11);
        let inputs = (0..n)
            .map(|i| {
                let wobble = handheld.then(|| (Wobble::new(&mut rng), Wobble::new(&mut rng)));
                InputCamera {
                    angle_rad: arc_angle_rad(i, n, layout.arc_deg),
                    height_m: CAMERA_HEIGHT_M + alternate_sign(i) * layout.height_spread_m,
                    intrinsics: layout.intrinsics(i, n, width, height),
                    wobble,
                }
            })
            .collect();
        Self {
            width,
            height,
            intrinsics: Intrinsics::from_vertical_fov(VERTICAL_FOV_DEG.to_radians(), width, height),
            inputs,
            duration_s: duration_s.max(1e-9),
            arc_deg: layout.arc_deg,
        }
    }

    /// Number of input cameras.
    pub fn input_count(&self) -> usize {
        self.inputs.len()
    }

    fn camera(&self, camera_from_world: Rigid3) -> Camera {
        Camera { intrinsics: self.intrinsics, camera_from_world, width_px: self.width, height_px: self.height }
    }

    /// Input camera `i` at time `t_s`.
    pub fn input(&self, i: usize, t_s: f64) -> Camera {
        let InputCamera { angle_rad, height_m, intrinsics, wobble } = &self.inputs[i];
        let eye = eye_on_arc(*angle_rad, ARC_RADIUS_M, *height_m);
        let mut pose = Rigid3::camera_from_world_looking_at(eye, LOOK_AT, DVec3::Y);
        if let Some((position, rotation)) = wobble {
            let eye = eye + position.at(t_s) * HANDHELD_POSITION_M;
            let base = Rigid3::camera_from_world_looking_at(eye, LOOK_AT, DVec3::Y);
            let shake: DMat3 = matrix_from_angle_axis(rotation.at(t_s) * HANDHELD_ROTATION_DEG.to_radians());
            pose = Rigid3::new(shake * base.rotation, shake * base.translation);
        }
        Camera { intrinsics: *intrinsics, camera_from_world: pose, width_px: self.width, height_px: self.height }
    }

    /// The held-out camera at time `t_s`: it sweeps across the middle of the arc, a little
    /// lower and closer than the inputs, so it always lies between input cameras.
    pub fn heldout(&self, t_s: f64) -> Camera {
        let u = (t_s / self.duration_s).clamp(0.0, 1.0);
        let half = 0.5 * self.arc_deg.to_radians() * HELDOUT_SWEEP;
        let angle = -half + 2.0 * half * u;
        let eye = eye_on_arc(angle, ARC_RADIUS_M * 0.92, CAMERA_HEIGHT_M - 0.15);
        self.camera(Rigid3::camera_from_world_looking_at(eye, LOOK_AT, DVec3::Y))
    }

    /// The static held-out camera: where the moving one passes at mid-event.
    pub fn heldout_static(&self) -> Camera {
        self.heldout(0.5 * self.duration_s)
    }
}

/// The held-out (ground-truth) cameras.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Heldout {
    /// Sweeps across the middle of the arc over the event (PSNR and SSIM).
    Moving,
    /// Stands still in the middle of the arc (flicker: its ground truth changes only where
    /// things move).
    Static,
}

impl Heldout {
    /// Both held-out cameras.
    pub const ALL: [Heldout; 2] = [Heldout::Moving, Heldout::Static];

    /// Folder and image-name prefix.
    pub fn name(self) -> &'static str {
        match self {
            Self::Moving => "heldout",
            Self::Static => "heldout_static",
        }
    }

    /// File name of its nerfstudio camera path.
    pub fn path_file(self) -> &'static str {
        match self {
            Self::Moving => "camera_path.json",
            Self::Static => "camera_path_static.json",
        }
    }

    /// The camera at time `t_s`.
    pub fn camera(self, rig: &Rig, t_s: f64) -> Camera {
        match self {
            Self::Moving => rig.heldout(t_s),
            Self::Static => rig.heldout_static(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inputs_span_sixty_degrees_and_look_at_the_scene() {
        let rig = Rig::new(6, 96, 54, false, 1, 1.0);
        let first = rig.input(0, 0.0).center_world() - LOOK_AT;
        let last = rig.input(5, 0.0).center_world() - LOOK_AT;
        let angle = (first.x.atan2(first.z) - last.x.atan2(last.z)).abs().to_degrees();
        assert!((angle - 60.0).abs() < 1e-9, "{angle}");
        for i in 0..6 {
            let (px, _) = rig.input(i, 0.0).project_world(LOOK_AT).unwrap();
            assert!((px.x - 47.5).abs() < 1e-9 && (px.y - 26.5).abs() < 1e-9);
        }
    }

    #[test]
    fn a_layout_sets_the_arc_the_focals_and_the_principal_points() {
        let layout = Layout { arc_deg: 90.0, focal_range: Some([0.8, 1.6]), principal_offset_px: [3.0, -2.0], ..Layout::default() };
        let rig = Rig::with_layout(5, 96, 54, false, 1, 1.0, &layout);
        let first = rig.input(0, 0.0).center_world() - LOOK_AT;
        let last = rig.input(4, 0.0).center_world() - LOOK_AT;
        let angle = (first.x.atan2(first.z) - last.x.atan2(last.z)).abs().to_degrees();
        assert!((angle - 90.0).abs() < 1e-9, "{angle}");
        let k: Vec<Intrinsics> = (0..5).map(|i| rig.input(i, 0.0).intrinsics).collect();
        for (i, factor) in [(0, 0.8), (2, 1.2), (4, 1.6)] {
            assert!((k[i].fx - factor * 96.0).abs() < 1e-9 && k[i].fy == k[i].fx, "{:?}", k[i]);
        }
        assert_eq!((k[0].cx, k[0].cy, k[1].cx, k[1].cy), (47.5 + 3.0, 26.5 - 2.0, 47.5 - 3.0, 26.5 + 2.0));
        // Every input still sees the scene's centre.
        for (i, k) in k.iter().enumerate() {
            let (px, _) = rig.input(i, 0.0).project_world(LOOK_AT).unwrap();
            assert!((px.x - k.cx).abs() < 1e-9 && (px.y - k.cy).abs() < 1e-9);
        }
        // The default layout is the 60-degree arc of `Rig::new`.
        assert_eq!(
            Rig::with_layout(6, 96, 54, true, 1, 1.0, &Layout::default()).input(3, 0.2),
            Rig::new(6, 96, 54, true, 1, 1.0).input(3, 0.2)
        );
    }

    #[test]
    fn a_height_spread_stands_the_cameras_above_and_below_alternately_looking_at_the_centre() {
        let layout = Layout { height_spread_m: 0.5, ..Layout::default() };
        let rig = Rig::with_layout(4, 96, 54, false, 1, 1.0, &layout);
        for i in 0..4 {
            let camera = rig.input(i, 0.0);
            let expected = CAMERA_HEIGHT_M + if i % 2 == 0 { 0.5 } else { -0.5 };
            assert!((camera.center_world().y - expected).abs() < 1e-9, "camera {i}: {}", camera.center_world().y);
            let (px, _) = camera.project_world(LOOK_AT).unwrap();
            assert!((px.x - 47.5).abs() < 1e-9 && (px.y - 26.5).abs() < 1e-9, "camera {i} looks at {px:?}");
        }
    }

    #[test]
    fn handheld_wobble_is_small_and_smooth() {
        let rig = Rig::new(3, 96, 54, true, 9, 1.0);
        let still = Rig::new(3, 96, 54, false, 9, 1.0);
        let mut max_offset: f64 = 0.0;
        for k in 0..30 {
            let t = k as f64 / 30.0;
            let d = (rig.input(1, t).center_world() - still.input(1, 0.0).center_world()).length();
            max_offset = max_offset.max(d);
            let step = (rig.input(1, t + 1.0 / 30.0).center_world() - rig.input(1, t).center_world()).length();
            assert!(step < 0.02, "jump of {step} m in one frame");
        }
        assert!(max_offset > 0.003 && max_offset < 0.1, "{max_offset}");
    }

    #[test]
    fn heldout_stays_between_inputs() {
        let rig = Rig::new(6, 96, 54, false, 1, 2.0);
        let angle = |c: Camera| {
            let v = c.center_world() - LOOK_AT;
            v.x.atan2(v.z)
        };
        let (lo, hi) = (angle(rig.input(0, 0.0)), angle(rig.input(5, 0.0)));
        for k in 0..=10 {
            let a = angle(rig.heldout(k as f64 * 0.2));
            assert!(a > lo && a < hi);
        }
        assert!((angle(rig.heldout(0.0)) - angle(rig.heldout(2.0))).abs() > 0.3);
    }
}
