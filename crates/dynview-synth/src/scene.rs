//! The synthetic event: a ground, a back wall, static objects and moving objects, with exact
//! ray intersection. World axes: y up, metres; the action happens around the origin.

use glam::{DMat3, DVec3};

use crate::texture::Texture;

/// A shape in its own frame.
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    /// A rectangle in the local plane `y = 0`, facing `+y`, spanning `[-hx, hx] x [-hz, hz]`.
    Rect {
        /// Half extent along local x.
        half_x: f64,
        /// Half extent along local z.
        half_z: f64,
    },
    /// A box centred on the local origin.
    Cuboid {
        /// Half extents.
        half: DVec3,
    },
    /// A sphere centred on the local origin.
    Sphere {
        /// Radius.
        radius: f64,
    },
    /// A capped cylinder along local y from 0 to `height`.
    Cylinder {
        /// Radius.
        radius: f64,
        /// Height.
        height: f64,
    },
}

/// How an object moves: its pose at time `t` seconds.
#[derive(Clone, Copy, Debug)]
pub enum Motion {
    /// Fixed pose.
    Static {
        /// Rotation of the object frame.
        rotation: DMat3,
        /// Position of the object origin.
        position: DVec3,
    },
    /// Slides along x on a sine and bounces (a ball).
    Bouncing {
        /// Centre of the motion.
        centre: DVec3,
        /// Amplitude along x (m).
        amplitude_x: f64,
        /// Bounce height (m).
        bounce_m: f64,
        /// Period of the x motion (s).
        period_s: f64,
    },
    /// Turns about the vertical axis while drifting along z.
    Spinning {
        /// Centre of the motion.
        centre: DVec3,
        /// Turn rate (rad/s).
        rate_rad_s: f64,
        /// Amplitude of the drift along z (m).
        drift_z: f64,
        /// Period of the drift (s).
        period_s: f64,
    },
}

impl Motion {
    /// The object's `world_from_local` pose at time `t_s`: (rotation, position).
    pub fn pose(&self, t_s: f64) -> (DMat3, DVec3) {
        use std::f64::consts::TAU;
        match *self {
            Self::Static { rotation, position } => (rotation, position),
            Self::Bouncing { centre, amplitude_x, bounce_m, period_s } => {
                let phase = TAU * t_s / period_s;
                let x = amplitude_x * phase.sin();
                let y = bounce_m * (2.0 * phase).sin().abs();
                // The ball rolls: rotation about z proportional to the travelled distance.
                (DMat3::from_rotation_z(-x / 0.45), centre + DVec3::new(x, y, 0.0))
            }
            Self::Spinning { centre, rate_rad_s, drift_z, period_s } => {
                let z = drift_z * (TAU * t_s / period_s).sin();
                (DMat3::from_rotation_y(rate_rad_s * t_s), centre + DVec3::new(0.0, 0.0, z))
            }
        }
    }

    /// The times in `[from_s, to_s]` at which a bouncing object touches down (its height above
    /// the centre of its motion is zero: `|sin(2 phase)| = 0`, every quarter period), in
    /// order; empty for the other motions.
    pub fn contact_times_s(&self, from_s: f64, to_s: f64) -> Vec<f64> {
        let Self::Bouncing { period_s, .. } = *self else { return Vec::new() };
        let quarter_s = 0.25 * period_s;
        let (first, last) = ((from_s / quarter_s).ceil() as i64, (to_s / quarter_s).floor() as i64);
        (first..=last).map(|k| k as f64 * quarter_s).collect()
    }

    /// True when the object moves.
    pub fn is_dynamic(&self) -> bool {
        !matches!(self, Self::Static { .. })
    }
}

/// One object of the scene.
#[derive(Clone, Copy, Debug)]
pub struct Object {
    /// Its shape.
    pub shape: Shape,
    /// Its texture (in the object's frame).
    pub texture: Texture,
    /// Its motion.
    pub motion: Motion,
}

impl Object {
    /// Whether it moves.
    pub fn moves(&self) -> bool {
        !matches!(self.motion, Motion::Static { .. })
    }

    /// A short name from its texture, motion and shape, e.g. `bouncing sphere`, `plain
    /// spinning box`.
    pub fn label(&self) -> String {
        let motion = match self.motion {
            Motion::Static { .. } => "static",
            Motion::Bouncing { .. } => "bouncing",
            Motion::Spinning { .. } => "spinning",
        };
        let shape = match self.shape {
            Shape::Rect { .. } => "plane",
            Shape::Cuboid { .. } => "box",
            Shape::Sphere { .. } => "sphere",
            Shape::Cylinder { .. } => "cylinder",
        };
        let plain = if self.texture.is_plain() { "plain " } else { "" };
        format!("{plain}{motion} {shape}")
    }
}

/// A ray hit: distance along the ray, world normal, point in the object's frame.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Ray parameter (distance for unit directions).
    pub t: f64,
    /// Unit normal in world coordinates, facing the ray origin.
    pub normal_world: DVec3,
    /// Hit point in the object's frame (texture coordinates).
    pub point_local: DVec3,
    /// Index of the object.
    pub object: usize,
}

const EPS: f64 = 1e-9;

fn intersect_local(shape: &Shape, o: DVec3, d: DVec3) -> Option<(f64, DVec3)> {
    match *shape {
        Shape::Rect { half_x, half_z } => {
            if d.y.abs() < EPS {
                return None;
            }
            let t = -o.y / d.y;
            let p = o + d * t;
            (t > EPS && p.x.abs() <= half_x && p.z.abs() <= half_z).then_some((t, DVec3::Y))
        }
        Shape::Cuboid { half } => {
            let inv = d.recip();
            let t0 = (-half - o) * inv;
            let t1 = (half - o) * inv;
            let tmin = t0.min(t1);
            let tmax = t0.max(t1);
            let near = tmin.max_element();
            let far = tmax.min_element();
            if near > far || far < EPS {
                return None;
            }
            let t = if near > EPS { near } else { far };
            let p = o + d * t;
            // Normal of the face hit: the axis where |p| / half is largest.
            let r = p / half;
            let a = r.abs();
            let n = if a.x >= a.y && a.x >= a.z {
                DVec3::new(r.x.signum(), 0.0, 0.0)
            } else if a.y >= a.z {
                DVec3::new(0.0, r.y.signum(), 0.0)
            } else {
                DVec3::new(0.0, 0.0, r.z.signum())
            };
            Some((t, n))
        }
        Shape::Sphere { radius } => {
            let b = o.dot(d);
            let c = o.length_squared() - radius * radius;
            let a = d.length_squared();
            let disc = b * b - a * c;
            if disc < 0.0 {
                return None;
            }
            let s = disc.sqrt();
            let t = if (-b - s) / a > EPS { (-b - s) / a } else { (-b + s) / a };
            (t > EPS).then(|| (t, (o + d * t) / radius))
        }
        Shape::Cylinder { radius, height } => {
            let mut best: Option<(f64, DVec3)> = None;
            let a = d.x * d.x + d.z * d.z;
            if a > EPS {
                let b = o.x * d.x + o.z * d.z;
                let c = o.x * o.x + o.z * o.z - radius * radius;
                let disc = b * b - a * c;
                if disc >= 0.0 {
                    for t in [(-b - disc.sqrt()) / a, (-b + disc.sqrt()) / a] {
                        let p = o + d * t;
                        if t > EPS && (0.0..=height).contains(&p.y) {
                            best = Some((t, DVec3::new(p.x, 0.0, p.z) / radius));
                            break;
                        }
                    }
                }
            }
            if d.y.abs() > EPS {
                for (y, n) in [(0.0, DVec3::NEG_Y), (height, DVec3::Y)] {
                    let t = (y - o.y) / d.y;
                    let p = o + d * t;
                    if t > EPS && p.x * p.x + p.z * p.z <= radius * radius && best.is_none_or(|(bt, _)| t < bt) {
                        best = Some((t, n));
                    }
                }
            }
            best
        }
    }
}

/// The whole scene at one instant: objects with their poses resolved.
#[derive(Clone, Debug)]
pub struct Frame<'a> {
    objects: &'a [Object],
    /// Per object: (world_from_local rotation, position).
    poses: Vec<(DMat3, DVec3)>,
}

impl<'a> Frame<'a> {
    /// The scene at time `t_s`.
    pub fn at(objects: &'a [Object], t_s: f64) -> Self {
        Self { objects, poses: objects.iter().map(|o| o.motion.pose(t_s)).collect() }
    }

    /// Nearest hit along the ray (`direction` need not be unit; `t` is in its units).
    pub fn trace(&self, origin: DVec3, direction: DVec3) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        for (i, (object, (rotation, position))) in self.objects.iter().zip(&self.poses).enumerate() {
            let local_from_world = rotation.transpose();
            let o = local_from_world * (origin - *position);
            let d = local_from_world * direction;
            if let Some((t, n_local)) = intersect_local(&object.shape, o, d)
                && best.is_none_or(|b| t < b.t)
            {
                let mut n = *rotation * n_local;
                if n.dot(direction) > 0.0 {
                    n = -n;
                }
                best = Some(Hit { t, normal_world: n, point_local: o + d * t, object: i });
            }
        }
        best
    }

    /// How far reconstructed points lie from the true surfaces: per point, the relative depth
    /// error along the ray from whichever of `origins` (camera centres) puts it closest to the
    /// surface it hits (infinite when no ray hits anything), sorted; and the number of points
    /// within 1% of a moving object.
    pub fn relative_depth_errors(&self, origins: &[DVec3], points: impl IntoIterator<Item = DVec3>) -> (Vec<f64>, usize) {
        let mut errors = Vec::new();
        let mut on_moving = 0;
        for point in points {
            let (mut error, mut object) = (f64::INFINITY, None);
            for &origin in origins {
                let distance = (point - origin).length();
                if let Some(hit) = self.trace(origin, (point - origin) / distance) {
                    let e = (hit.t - distance).abs() / distance;
                    if e < error {
                        (error, object) = (e, Some(hit.object));
                    }
                }
            }
            if object.is_some_and(|o| self.objects[o].motion.is_dynamic()) && error < 0.01 {
                on_moving += 1;
            }
            errors.push(error);
        }
        errors.sort_by(f64::total_cmp);
        (errors, on_moving)
    }

    /// True when anything lies on the segment from `origin` along `direction` (unit) before
    /// `max_t`.
    pub fn occluded(&self, origin: DVec3, direction: DVec3, max_t: f64) -> bool {
        self.trace(origin, direction).is_some_and(|h| h.t < max_t)
    }

    /// The objects.
    pub fn objects(&self) -> &[Object] {
        self.objects
    }
}

fn palette(a: [f32; 3], b: [f32; 3]) -> [[f32; 3]; 2] {
    [a, b]
}

/// The default event: ground, back wall, three static objects, a bouncing ball and a
/// spinning, drifting box. `seed` varies the textures.
pub fn default_objects(seed: u64) -> Vec<Object> {
    let tex = |k: u64, base: f64, spots: f64, p: [[f32; 3]; 2]| Texture {
        seed: seed.wrapping_mul(0x2545_F491_4F6C_DD1D).wrapping_add(k * 0x9E37_79B9),
        base_frequency: base,
        spot_frequency: spots,
        palette: p,
    };
    let fixed = |position: DVec3, yaw: f64| Motion::Static { rotation: DMat3::from_rotation_y(yaw), position };
    vec![
        // Ground.
        Object {
            shape: Shape::Rect { half_x: 25.0, half_z: 14.0 },
            texture: tex(1, 1.6, 2.2, palette([0.55, 0.45, 0.30], [0.25, 0.35, 0.20])),
            motion: fixed(DVec3::new(0.0, 0.0, 2.0), 0.0),
        },
        // Back wall: the plane's +y turned to face +z.
        Object {
            shape: Shape::Rect { half_x: 25.0, half_z: 4.0 },
            texture: tex(2, 1.3, 1.8, palette([0.75, 0.72, 0.65], [0.35, 0.30, 0.45])),
            motion: Motion::Static { rotation: DMat3::from_rotation_x(std::f64::consts::FRAC_PI_2), position: DVec3::new(0.0, 4.0, -4.0) },
        },
        // Static: a crate, a pillar, a ball.
        Object {
            shape: Shape::Cuboid { half: DVec3::new(0.45, 0.6, 0.45) },
            texture: tex(3, 3.0, 4.5, palette([0.80, 0.55, 0.25], [0.45, 0.25, 0.10])),
            motion: fixed(DVec3::new(-2.0, 0.6, -1.6), 0.35),
        },
        Object {
            shape: Shape::Cylinder { radius: 0.35, height: 2.4 },
            texture: tex(4, 3.5, 5.0, palette([0.30, 0.45, 0.75], [0.85, 0.85, 0.90])),
            motion: fixed(DVec3::new(2.3, 0.0, -2.4), 0.0),
        },
        Object {
            shape: Shape::Sphere { radius: 0.4 },
            texture: tex(5, 4.0, 6.0, palette([0.20, 0.60, 0.35], [0.90, 0.80, 0.30])),
            motion: fixed(DVec3::new(1.7, 0.4, 0.6), 0.0),
        },
        // Dynamic: a bouncing, rolling ball and a spinning box.
        Object {
            shape: Shape::Sphere { radius: 0.45 },
            texture: tex(6, 4.0, 6.5, palette([0.85, 0.20, 0.25], [0.95, 0.90, 0.85])),
            motion: Motion::Bouncing { centre: DVec3::new(-0.2, 0.45, 0.3), amplitude_x: 1.4, bounce_m: 0.35, period_s: 3.0 },
        },
        Object {
            shape: Shape::Cuboid { half: DVec3::new(0.4, 0.4, 0.4) },
            texture: tex(7, 3.5, 5.5, palette([0.60, 0.25, 0.70], [0.95, 0.75, 0.35])),
            motion: Motion::Spinning { centre: DVec3::new(0.4, 0.4, -1.3), rate_rad_s: 1.6, drift_z: 0.4, period_s: 2.5 },
        },
    ]
}

/// The hard moving things of issue 35, added by [`crate::SynthConfig::plain_movers`]: a small,
/// fast, untextured ball (15 cm in radius, two passes of 3.6 m a second, bouncing) and a plain-coloured box drifting
/// across the front, neither with any pattern for stereo to match.
pub fn plain_movers() -> Vec<Object> {
    vec![
        Object {
            shape: Shape::Sphere { radius: 0.15 },
            texture: Texture::plain([0.95, 0.55, 0.10]),
            motion: Motion::Bouncing { centre: DVec3::new(0.6, 0.15, 1.2), amplitude_x: 1.8, bounce_m: 0.5, period_s: 1.0 },
        },
        Object {
            shape: Shape::Cuboid { half: DVec3::new(0.3, 0.5, 0.3) },
            texture: Texture::plain([0.30, 0.45, 0.70]),
            motion: Motion::Spinning { centre: DVec3::new(-1.3, 0.5, 0.9), rate_rad_s: 0.8, drift_z: 0.6, period_s: 3.0 },
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_hand_checked() {
        let objects = [Object {
            shape: Shape::Sphere { radius: 1.0 },
            texture: default_objects(0)[0].texture,
            motion: Motion::Static { rotation: DMat3::IDENTITY, position: DVec3::new(0.0, 0.0, 5.0) },
        }];
        let frame = Frame::at(&objects, 0.0);
        let hit = frame.trace(DVec3::ZERO, DVec3::Z).unwrap();
        assert!((hit.t - 4.0).abs() < 1e-12);
        assert!((hit.normal_world - DVec3::NEG_Z).length() < 1e-12);
        assert!(frame.trace(DVec3::ZERO, DVec3::X).is_none());
    }

    #[test]
    fn box_and_cylinder_and_rect() {
        let o = DVec3::new(0.0, 0.5, -5.0);
        let cube = intersect_local(&Shape::Cuboid { half: DVec3::splat(1.0) }, o, DVec3::Z).unwrap();
        assert!((cube.0 - 4.0).abs() < 1e-12 && cube.1 == DVec3::NEG_Z);
        let cyl = intersect_local(&Shape::Cylinder { radius: 1.0, height: 2.0 }, o, DVec3::Z).unwrap();
        assert!((cyl.0 - 4.0).abs() < 1e-12);
        let cap = intersect_local(&Shape::Cylinder { radius: 1.0, height: 2.0 }, DVec3::new(0.0, 5.0, 0.0), DVec3::NEG_Y).unwrap();
        assert!((cap.0 - 3.0).abs() < 1e-12 && cap.1 == DVec3::Y);
        let rect = intersect_local(&Shape::Rect { half_x: 1.0, half_z: 1.0 }, DVec3::new(0.5, 2.0, 0.0), DVec3::NEG_Y).unwrap();
        assert!((rect.0 - 2.0).abs() < 1e-12);
        assert!(intersect_local(&Shape::Rect { half_x: 1.0, half_z: 1.0 }, DVec3::new(1.5, 2.0, 0.0), DVec3::NEG_Y).is_none());
    }

    #[test]
    fn the_ball_touches_down_at_its_contact_times() {
        let objects = default_objects(1);
        let ball = objects.iter().find(|o| matches!(o.motion, Motion::Bouncing { .. })).unwrap();
        let Motion::Bouncing { centre, period_s, .. } = ball.motion else { unreachable!() };
        let contacts = ball.motion.contact_times_s(-1.0, 2.0);
        assert_eq!(contacts, [-0.75, 0.0, 0.75, 1.5]);
        for t in contacts {
            assert!((ball.motion.pose(t).1.y - centre.y).abs() < 1e-12, "{t}");
            // Up again just before and after.
            for dt in [-0.01, 0.01] {
                assert!(ball.motion.pose(t + dt).1.y - centre.y > 1e-3);
            }
        }
        assert!(period_s > 0.0 && objects[0].motion.contact_times_s(0.0, 9.0).is_empty());
    }

    #[test]
    fn dynamic_objects_move_and_one_rotates() {
        let objects = default_objects(1);
        let dynamic: Vec<_> = objects.iter().filter(|o| o.motion.is_dynamic()).collect();
        assert!(dynamic.len() >= 2);
        for o in &dynamic {
            let (_, p0) = o.motion.pose(0.0);
            let (_, p1) = o.motion.pose(0.5);
            assert!((p1 - p0).length() > 0.1);
        }
        let spinning = dynamic.iter().find(|o| matches!(o.motion, Motion::Spinning { .. })).unwrap();
        let (r0, _) = spinning.motion.pose(0.0);
        let (r1, _) = spinning.motion.pose(0.5);
        assert!(dynview_core::rotation::relative_angle_rad(r0, r1) > 0.5);
    }
}
