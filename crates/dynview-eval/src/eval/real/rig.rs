//! How the cameras of a capture stand around what they film: the point nearest every camera's
//! line of sight (the target), world up from the cameras' image up, and each camera's azimuth
//! and elevation seen from the target. `eval-real` leaves out the highest and the lowest
//! camera (views off the others' arc) and orbits a virtual camera off the arc with it.

use anyhow::bail;
use dynview_core::Rigid3;
use glam::{DMat3, DVec3};

/// One camera of a [`Rig`].
#[derive(Clone, Debug, PartialEq)]
pub struct RigCamera {
    /// The camera's name.
    pub name: String,
    /// Its centre (world).
    pub center_world: DVec3,
    /// Angle of its centre above the horizontal plane through the target, degrees.
    pub elevation_deg: f64,
    /// Angle of its centre around the up axis from the cameras' mean horizontal direction,
    /// degrees in (-180, 180].
    pub azimuth_deg: f64,
}

/// Cameras around a common target.
#[derive(Clone, Debug)]
pub struct Rig {
    /// The point nearest every camera's line of sight (least squares; world).
    pub target_world: DVec3,
    /// World up, unit length: the direction most nearly square to every camera's image x axis
    /// (cameras held level), on the side of their image up.
    pub up_world: DVec3,
    /// Horizontal unit direction of azimuth 0: the cameras' mean direction from the target.
    front_world: DVec3,
    /// Mean distance of the cameras from the target.
    pub distance: f64,
    /// The cameras, by azimuth.
    pub cameras: Vec<RigCamera>,
}

impl Rig {
    /// The rig of `cameras` (name and `camera_from_world`); an error when fewer than two are
    /// given, when their lines of sight are parallel or when they show no common up.
    pub fn new(cameras: &[(String, Rigid3)]) -> anyhow::Result<Self> {
        if cameras.len() < 2 {
            bail!("a rig needs at least two cameras, {} given", cameras.len());
        }
        let mut normal = DMat3::ZERO;
        let mut rhs = DVec3::ZERO;
        let mut up_sum = DVec3::ZERO;
        let mut across_x = DMat3::ZERO;
        let mut centers = Vec::with_capacity(cameras.len());
        for (_, camera_from_world) in cameras {
            let world_from_camera = camera_from_world.inverse();
            let center = world_from_camera.translation;
            // Distance to the line of sight: (I - f f^T)(x - c).
            let across = DMat3::IDENTITY - outer(world_from_camera.transform_vector(DVec3::Z).normalize());
            normal += across;
            rhs += across * center;
            up_sum += world_from_camera.transform_vector(DVec3::NEG_Y);
            across_x += outer(world_from_camera.transform_vector(DVec3::X));
            centers.push(center);
        }
        if normal.determinant().abs() < 1e-9 * cameras.len() as f64 {
            bail!("the cameras' lines of sight are parallel: no common target");
        }
        let target_world = normal.inverse() * rhs;
        let level = smallest_eigenvector(&across_x);
        let up_world = if level.dot(up_sum) < 0.0 { -level } else { level };
        let horizontal = |v: DVec3| v - up_world * v.dot(up_world);
        let front_world = horizontal(centers.iter().map(|c| (*c - target_world).normalize_or_zero()).sum()).normalize_or_zero();
        if up_world == DVec3::ZERO || front_world == DVec3::ZERO || !target_world.is_finite() {
            bail!("the cameras show no common up and front");
        }
        let side_world = up_world.cross(front_world);
        let mut rig_cameras: Vec<RigCamera> = cameras
            .iter()
            .zip(&centers)
            .map(|((name, _), center)| {
                let v = *center - target_world;
                RigCamera {
                    name: name.clone(),
                    center_world: *center,
                    elevation_deg: (v.dot(up_world) / v.length()).clamp(-1.0, 1.0).asin().to_degrees(),
                    azimuth_deg: v.dot(side_world).atan2(v.dot(front_world)).to_degrees(),
                }
            })
            .collect();
        rig_cameras.sort_by(|a, b| a.azimuth_deg.total_cmp(&b.azimuth_deg));
        let distance = centers.iter().map(|c| (*c - target_world).length()).sum::<f64>() / centers.len() as f64;
        Ok(Self { target_world, up_world, front_world, distance, cameras: rig_cameras })
    }

    /// The camera highest above the target's horizon and the lowest.
    pub fn highest_and_lowest(&self) -> (&RigCamera, &RigCamera) {
        let by_elevation = |a: &&RigCamera, b: &&RigCamera| a.elevation_deg.total_cmp(&b.elevation_deg);
        let highest = self.cameras.iter().max_by(by_elevation).expect("a rig has cameras");
        let lowest = self.cameras.iter().min_by(by_elevation).expect("a rig has cameras");
        (highest, lowest)
    }

    /// The elevation of the arc at `azimuth_deg`: interpolated between the cameras on either
    /// side, that of the nearer end camera outside them.
    pub fn arc_elevation_deg(&self, azimuth_deg: f64) -> f64 {
        let cams = &self.cameras;
        let after = cams.iter().position(|c| c.azimuth_deg >= azimuth_deg);
        match after {
            None => cams[cams.len() - 1].elevation_deg,
            Some(0) => cams[0].elevation_deg,
            Some(i) => {
                let (a, b) = (&cams[i - 1], &cams[i]);
                let span = b.azimuth_deg - a.azimuth_deg;
                let s = if span > 0.0 { (azimuth_deg - a.azimuth_deg) / span } else { 0.0 };
                a.elevation_deg + s * (b.elevation_deg - a.elevation_deg)
            }
        }
    }

    /// A camera centre `self.distance` from the target at `azimuth_deg` and `elevation_deg`.
    pub fn eye_world(&self, azimuth_deg: f64, elevation_deg: f64) -> DVec3 {
        let side_world = self.up_world.cross(self.front_world);
        let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
        let horizontal = self.front_world * az.cos() + side_world * az.sin();
        self.target_world + (horizontal * el.cos() + self.up_world * el.sin()) * self.distance
    }
}

/// `v v^T`.
fn outer(v: DVec3) -> DMat3 {
    DMat3::from_cols(v * v.x, v * v.y, v * v.z)
}

/// The unit eigenvector of the symmetric `m` with the smallest eigenvalue.
fn smallest_eigenvector(m: &DMat3) -> DVec3 {
    let a = nalgebra::Matrix3::from_fn(|r, c| m.col(c)[r]);
    let eigen = nalgebra::SymmetricEigen::new(a);
    let (i, _) = eigen.eigenvalues.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1)).expect("three eigenvalues");
    let v = eigen.eigenvectors.column(i);
    DVec3::new(v[0], v[1], v[2]).normalize_or_zero()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cameras `distance` from `target` at the given (azimuth, elevation) in degrees, looking at
    /// it, in a world whose up is -y (as Panoptic's).
    fn ring(target: DVec3, distance: f64, placements: &[(f64, f64)]) -> Vec<(String, Rigid3)> {
        let up = DVec3::NEG_Y;
        let front = DVec3::Z;
        let side = up.cross(front);
        placements
            .iter()
            .enumerate()
            .map(|(i, &(az, el))| {
                let (az, el) = (f64::to_radians(az), f64::to_radians(el));
                let eye = target + ((front * az.cos() + side * az.sin()) * el.cos() + up * el.sin()) * distance;
                (format!("cam{i}"), Rigid3::camera_from_world_looking_at(eye, target, up))
            })
            .collect()
    }

    #[test]
    fn the_target_up_and_each_cameras_place_are_found() {
        let target = DVec3::new(0.5, -1.4, 0.2);
        let placements = [(-60.0, 5.0), (-20.0, 25.0), (20.0, -10.0), (60.0, 0.0)];
        let rig = Rig::new(&ring(target, 3.0, &placements)).unwrap();
        assert!((rig.target_world - target).length() < 1e-9, "{:?}", rig.target_world);
        assert!((rig.up_world - DVec3::NEG_Y).length() < 1e-9, "{:?}", rig.up_world);
        assert!((rig.distance - 3.0).abs() < 1e-9);
        // Azimuths are measured from the cameras' mean direction: symmetric here.
        for (camera, (az, el)) in rig.cameras.iter().zip(placements) {
            assert!((camera.elevation_deg - el).abs() < 1e-6, "{camera:?}");
            assert!((camera.azimuth_deg.abs() - f64::abs(az)).abs() < 3.0, "{camera:?}");
        }
        let (highest, lowest) = rig.highest_and_lowest();
        assert_eq!((highest.name.as_str(), lowest.name.as_str()), ("cam1", "cam2"));
        // An eye placed at a camera's own azimuth and elevation is that camera's centre.
        let c = &rig.cameras[1];
        assert!((rig.eye_world(c.azimuth_deg, c.elevation_deg) - c.center_world).length() < 1e-6);
        // Between two cameras the arc's elevation is interpolated; beyond the ends it is the end's.
        let (a, b) = (&rig.cameras[1], &rig.cameras[2]);
        let middle = rig.arc_elevation_deg(0.5 * (a.azimuth_deg + b.azimuth_deg));
        assert!((middle - 0.5 * (a.elevation_deg + b.elevation_deg)).abs() < 1e-9);
        assert_eq!(rig.arc_elevation_deg(-170.0), rig.cameras[0].elevation_deg);
        assert_eq!(rig.arc_elevation_deg(170.0), rig.cameras[3].elevation_deg);
    }

    #[test]
    fn cameras_that_share_no_target_are_refused() {
        assert!(Rig::new(&ring(DVec3::ZERO, 2.0, &[(0.0, 0.0)])).unwrap_err().to_string().contains("at least two"));
        // Two cameras looking the same way along parallel lines.
        let a = Rigid3::camera_from_world_looking_at(DVec3::ZERO, DVec3::Z, DVec3::NEG_Y);
        let b = Rigid3::camera_from_world_looking_at(DVec3::X, DVec3::X + DVec3::Z, DVec3::NEG_Y);
        let err = Rig::new(&[("a".into(), a), ("b".into(), b)]).unwrap_err();
        assert!(err.to_string().contains("parallel"), "{err}");
    }
}
