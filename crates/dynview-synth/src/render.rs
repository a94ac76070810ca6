//! Ray tracing a camera view: color (supersampled) and exact z-depth per pixel centre.

use glam::DVec3;
use rayon::prelude::*;

use dynview_core::{Camera, Raster, RgbRaster, ScalarRaster};

use crate::scene::Frame;

/// Direction towards the sun (unit).
const SUN_DIR: DVec3 = DVec3::new(0.42, 0.82, 0.39);
/// Ambient light share.
const AMBIENT: f32 = 0.42;
/// Direct light share.
const DIRECT: f32 = 0.62;
/// Offset along the normal for shadow rays (m).
const SHADOW_BIAS_M: f64 = 1e-4;

/// A rendered view: color, and z-depth in metres (`NaN` where the ray hits nothing).
#[derive(Clone, Debug)]
pub struct View {
    /// Color.
    pub color: RgbRaster,
    /// z-depth at pixel centres.
    pub depth_m: ScalarRaster,
    /// What the ray through each pixel centre hits: 1 + the object's index in the frame's
    /// objects, 0 where it hits nothing.
    pub object: Raster<u8>,
}

fn sky(direction: DVec3) -> [f32; 3] {
    let up = (direction.normalize().y as f32).clamp(0.0, 1.0);
    [0.62 - 0.25 * up, 0.74 - 0.2 * up, 0.92 - 0.05 * up]
}

fn shade(frame: &Frame, origin: DVec3, direction: DVec3) -> ([f32; 3], Option<f64>) {
    let Some(hit) = frame.trace(origin, direction) else {
        return (sky(direction), None);
    };
    let albedo = frame.objects()[hit.object].texture.albedo(hit.point_local);
    let sun = SUN_DIR.normalize();
    let lambert = hit.normal_world.dot(sun).max(0.0) as f32;
    let point = origin + direction * hit.t;
    let lit = if lambert > 0.0 && !frame.occluded(point + hit.normal_world * SHADOW_BIAS_M, sun, f64::INFINITY) { lambert } else { 0.0 };
    let light = AMBIENT + DIRECT * lit;
    (albedo.map(|a| (a * light).min(1.0)), Some(hit.t))
}

/// One row of a view: colors, depths and object ids.
type RowSamples = (Vec<[f32; 3]>, Vec<f32>, Vec<u8>);

/// Renders `camera` on `frame`. Color is the trapezoid-weighted mean of a grid of
/// `(supersample + 1)^2` samples spanning each pixel's footprint; samples on pixel borders are
/// shared with the neighbours, so the cost is about `supersample^2` shades per pixel. Depth
/// is traced through the exact pixel centre.
pub fn render_view(frame: &Frame, camera: &Camera, supersample: u32) -> View {
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    let world_from_camera = camera.camera_from_world.inverse();
    let origin = world_from_camera.translation;
    let k = camera.intrinsics;
    let s = supersample.max(1) as usize;
    let ray = |x: f64, y: f64| {
        // z-depth along this direction equals the ray parameter: direction has z = 1.
        let d_camera = DVec3::new((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0);
        world_from_camera.transform_vector(d_camera)
    };
    // Sample grid: (s w + 1) x (s h + 1) points from (-0.5, -0.5) in steps of 1/s.
    let (gw, gh) = (s * w + 1, s * h + 1);
    let step = 1.0 / s as f64;
    let grid: Vec<Vec<[f32; 3]>> = (0..gh)
        .into_par_iter()
        .map(|gy| {
            let y = -0.5 + gy as f64 * step;
            (0..gw).map(|gx| shade(frame, origin, ray(-0.5 + gx as f64 * step, y)).0).collect()
        })
        .collect();
    // Trapezoid weights along one axis: half weight on the pixel's border samples.
    let weights: Vec<f32> = (0..=s).map(|i| if i == 0 || i == s { 0.5 } else { 1.0 }).collect();
    let norm = 1.0 / (s as f32 * s as f32);
    let rows: Vec<RowSamples> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut colors = Vec::with_capacity(w);
            let mut depths = Vec::with_capacity(w);
            let mut objects = Vec::with_capacity(w);
            for x in 0..w {
                let hit = frame.trace(origin, ray(x as f64, y as f64));
                depths.push(hit.map_or(f32::NAN, |hit| hit.t as f32));
                objects.push(hit.map_or(0, |hit| u8::try_from(hit.object + 1).unwrap_or(u8::MAX)));
                let mut sum = [0.0f32; 3];
                for (j, wy) in weights.iter().enumerate() {
                    let row = &grid[y * s + j];
                    for (i, wx) in weights.iter().enumerate() {
                        let c = row[x * s + i];
                        let wgt = wx * wy;
                        for ch in 0..3 {
                            sum[ch] += wgt * c[ch];
                        }
                    }
                }
                colors.push(sum.map(|v| v * norm));
            }
            (colors, depths, objects)
        })
        .collect();
    let mut color = Vec::with_capacity(w * h);
    let mut depth = Vec::with_capacity(w * h);
    let mut object = Vec::with_capacity(w * h);
    for (c, d, o) in rows {
        color.extend(c);
        depth.extend(d);
        object.extend(o);
    }
    View {
        color: RgbRaster { width: w, height: h, data: color },
        depth_m: ScalarRaster { width: w, height: h, data: depth },
        object: Raster { width: w, height: h, data: object },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rig::Rig;
    use crate::scene::default_objects;
    use glam::DVec2;

    #[test]
    fn depth_unprojects_onto_surfaces_seen_by_other_cameras() {
        let objects = default_objects(3);
        let frame = Frame::at(&objects, 0.2);
        let rig = Rig::new(3, 80, 45, false, 3, 1.0);
        let a = rig.input(0, 0.2);
        let b = rig.input(2, 0.2);
        let view_a = render_view(&frame, &a, 1);
        let view_b = render_view(&frame, &b, 1);
        let mut agree = 0;
        let mut checked = 0;
        for y in (0..45).step_by(3) {
            for x in (0..80).step_by(3) {
                let d = view_a.depth_m.get(x, y);
                if d.is_nan() {
                    continue;
                }
                let p = a.unproject_world(DVec2::new(x as f64, y as f64), f64::from(d));
                let Some((px, depth_b)) = b.project_world(p) else { continue };
                if !b.contains(px) {
                    continue;
                }
                let (bx, by) = (px.x.round() as usize, px.y.round() as usize);
                checked += 1;
                // Visible in b (not occluded): b's depth agrees with the point's depth.
                if (f64::from(view_b.depth_m.get(bx, by)) - depth_b).abs() < 0.05 * depth_b {
                    agree += 1;
                }
            }
        }
        assert!(checked > 200);
        assert!(agree as f64 > 0.7 * checked as f64, "{agree}/{checked}");
    }

    #[test]
    fn object_ids_say_what_each_pixel_centre_hits() {
        let objects = default_objects(3);
        let frame = Frame::at(&objects, 0.2);
        let camera = Rig::new(3, 80, 45, false, 3, 1.0).input(1, 0.2);
        let view = render_view(&frame, &camera, 1);
        let world_from_camera = camera.camera_from_world.inverse();
        let k = camera.intrinsics;
        let mut seen = std::collections::BTreeSet::new();
        for y in 0..45 {
            for x in 0..80 {
                let id = view.object.get(x, y);
                assert_eq!(id == 0, view.depth_m.get(x, y).is_nan(), "({x}, {y})");
                let direction = world_from_camera.transform_vector(DVec3::new((x as f64 - k.cx) / k.fx, (y as f64 - k.cy) / k.fy, 1.0));
                let hit = frame.trace(world_from_camera.translation, direction).map_or(0, |h| h.object + 1);
                assert_eq!(usize::from(id), hit, "({x}, {y})");
                seen.insert(id);
            }
        }
        assert!(seen.len() >= 4, "the view shows several objects: {seen:?}");
    }
}
