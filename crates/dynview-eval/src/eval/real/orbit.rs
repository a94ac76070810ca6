//! Views away from the arc (issue 35): one time step of a package rendered by a virtual camera
//! that orbits the cameras' target along their arc and [`OFF_ARC_DEG`] above it, the full
//! method and the blend. A moving object whose depth is wrong lands in a different place from
//! each input view there: shown twice or three times, or as a ghost beside itself. The strip
//! lets a person check that each moving object is shown once.

use dynview_core::render::{Method, RenderHooks, RenderParams, StreamingRenderer};
use dynview_core::scene::ScenePackage;
use dynview_core::{Camera, RgbRaster, Rigid3};

use super::rig::Rig;

/// How far above the arc the second and third rows orbit, degrees.
pub(super) const OFF_ARC_DEG: f64 = 20.0;
/// Views along the orbit: from the second camera's azimuth to the second to last's.
pub(super) const VIEWS: usize = 5;

/// The rows of an orbit strip of `package` at time step `step`: the full method along the arc,
/// the full method [`OFF_ARC_DEG`] above it, and the blend there; each view at the size and
/// intrinsics of the package's first camera, looking at the rig's target.
pub(super) fn orbit_rows(package: &ScenePackage, rig: &Rig, step: u32, params: &RenderParams) -> anyhow::Result<Vec<Vec<RgbRaster>>> {
    let first = package.camera(0, step)?;
    let inputs = package.time_step_inputs(step, params.levels)?;
    let cams = &rig.cameras;
    let (from, to) = if cams.len() >= 4 {
        (cams[1].azimuth_deg, cams[cams.len() - 2].azimuth_deg)
    } else {
        (cams[0].azimuth_deg, cams[cams.len() - 1].azimuth_deg)
    };
    let mut rows = vec![Vec::new(), Vec::new(), Vec::new()];
    for i in 0..VIEWS {
        let azimuth_deg = from + (to - from) * i as f64 / (VIEWS - 1) as f64;
        let on_arc_deg = rig.arc_elevation_deg(azimuth_deg);
        for (row, elevation_deg, method) in
            [(0, on_arc_deg, Method::Full), (1, on_arc_deg + OFF_ARC_DEG, Method::Full), (2, on_arc_deg + OFF_ARC_DEG, Method::Blend)]
        {
            let eye = rig.eye_world(azimuth_deg, elevation_deg);
            let camera = Camera { camera_from_world: Rigid3::camera_from_world_looking_at(eye, rig.target_world, rig.up_world), ..first };
            let params = RenderParams { method, ..params.clone() };
            let out = StreamingRenderer::new().render(&params, &camera, &inputs, &mut RenderHooks::default())?;
            rows[row].push(out.color);
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use dynview_synth::SynthConfig;

    use super::*;

    #[test]
    fn the_orbit_renders_each_row_along_the_arc_and_above_it() {
        let dir = tempfile::tempdir().unwrap();
        let config = SynthConfig { frames: 1, width: 64, height: 36, videos: false, ..SynthConfig::default() };
        dynview_synth::generate(&config, dir.path(), &|_, _, _| {}).unwrap();
        let package = ScenePackage::open(dir.path().join("scene")).unwrap();
        let cameras: Vec<(String, Rigid3)> = package
            .manifest()
            .cameras
            .iter()
            .enumerate()
            .map(|(k, c)| (c.name.clone(), package.camera(k, 0).unwrap().camera_from_world))
            .collect();
        let rig = Rig::new(&cameras).unwrap();
        let rows = orbit_rows(&package, &rig, 0, &RenderParams::default()).unwrap();
        assert_eq!(rows.len(), 3);
        for row in &rows {
            assert_eq!(row.len(), VIEWS);
            for panel in row {
                assert_eq!((panel.width, panel.height), (64, 36));
                assert!(panel.data.iter().flatten().all(|v| v.is_finite()));
            }
        }
        // The views above the arc see the scene from elsewhere than those on it.
        let difference: f32 =
            rows[0][2].data.iter().zip(&rows[1][2].data).map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).abs()).sum::<f32>()).sum();
        assert!(difference / (64.0 * 36.0) > 0.01, "mean difference {}", difference / (64.0 * 36.0));
    }
}
