//! Depth error on the synthetic event's moving objects, as the held-out camera sees them: the
//! event's object ids (`heldout/object/`, `dynview synth`) pick each moving object's pixels, its
//! true depth (`heldout/depth/`) is compared with the depth a method rendered there.

use std::path::Path;

use anyhow::Context;
use dynview_core::depth_io::{DepthScale, SCALE_FILE, depth_from_image};
use dynview_core::{Raster, ScalarRaster};
use dynview_synth::{OBJECT_DIR, OBJECTS_FILE, ObjectEntry};

use crate::align::median;

/// A held-out camera's true depth and object ids at each time step, and the event's moving
/// objects.
pub struct ObjectTruth {
    /// The moving objects, in the event's order.
    pub moving: Vec<ObjectEntry>,
    depth_m: Vec<ScalarRaster>,
    ids: Vec<Raster<u8>>,
}

impl ObjectTruth {
    /// Reads the first `frames` time steps of `event/folder` (`heldout` or `heldout_static`).
    pub fn load(event: &Path, folder: &str, frames: usize) -> anyhow::Result<Self> {
        let root = event.join(folder);
        let list_path = root.join(OBJECT_DIR).join(OBJECTS_FILE);
        let list: Vec<ObjectEntry> =
            serde_json::from_slice(&std::fs::read(&list_path).with_context(|| format!("reading {}", list_path.display()))?)
                .with_context(|| format!("{}: not a list of objects", list_path.display()))?;
        let scale_path = root.join("depth").join(SCALE_FILE);
        let scale: DepthScale =
            serde_json::from_slice(&std::fs::read(&scale_path).with_context(|| format!("reading {}", scale_path.display()))?)
                .with_context(|| format!("{}: not a depth scale", scale_path.display()))?;
        let mut depth_m = Vec::with_capacity(frames);
        let mut ids = Vec::with_capacity(frames);
        for t in 0..frames {
            let file = format!("{t:05}.png");
            let depth_path = root.join("depth").join(&file);
            let depth = image::open(&depth_path).with_context(|| format!("reading {}", depth_path.display()))?.to_luma16();
            let id_path = root.join(OBJECT_DIR).join(&file);
            let id = image::open(&id_path).with_context(|| format!("reading {}", id_path.display()))?.to_luma8();
            if id.dimensions() != depth.dimensions() {
                anyhow::bail!("{}: {:?} pixels, its depth {:?}", id_path.display(), id.dimensions(), depth.dimensions());
            }
            depth_m.push(depth_from_image(&depth, scale));
            ids.push(Raster { width: id.width() as usize, height: id.height() as usize, data: id.into_raw() });
        }
        Ok(Self { moving: list.into_iter().filter(|o| o.moving).collect(), depth_m, ids })
    }

    /// Per moving object ([`ObjectTruth::moving`]'s order), the median of `|d - true| / true`
    /// in % over its pixels at every time step, where `d` is the rendered depth times
    /// `truth_per_rendered` (the true world's units per the rendered world's); `NaN` for an
    /// object never seen. `rendered[t]` must have the held-out camera's size.
    pub fn depth_errors_pct(&self, rendered: &[&ScalarRaster], truth_per_rendered: f64) -> Vec<f64> {
        // One pass over the pixels: each moving object's id to its slot.
        let mut slot_of_id = [None; 256];
        for (slot, object) in self.moving.iter().enumerate() {
            slot_of_id[usize::from(object.id)] = Some(slot);
        }
        let mut errors: Vec<Vec<f64>> = vec![Vec::new(); self.moving.len()];
        for ((ids, truth), depth) in self.ids.iter().zip(&self.depth_m).zip(rendered) {
            for ((&id, &true_m), &d) in ids.data.iter().zip(&truth.data).zip(&depth.data) {
                if let Some(slot) = slot_of_id[usize::from(id)]
                    && true_m.is_finite()
                    && true_m > 0.0
                {
                    let d = if d.is_finite() { f64::from(d) * truth_per_rendered } else { 0.0 };
                    errors[slot].push((d - f64::from(true_m)).abs() / f64::from(true_m));
                }
            }
        }
        errors.iter().map(|e| if e.is_empty() { f64::NAN } else { median(e) * 100.0 }).collect()
    }
}

/// Per-object depth errors as a table cell: `1.2 / 3.4` (`-` for an object never seen).
pub(crate) fn depth_errors_cell(errors_pct: &[f64]) -> String {
    errors_pct.iter().map(|e| if e.is_finite() { format!("{e:.1}") } else { "-".into() }).collect::<Vec<_>>().join(" / ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn truth() -> ObjectTruth {
        let entry = |id, moving| ObjectEntry { id, label: format!("object {id}"), moving };
        ObjectTruth {
            moving: vec![entry(2, true), entry(3, true)],
            depth_m: vec![ScalarRaster { width: 4, height: 1, data: vec![5.0, 2.0, 2.0, 4.0] }],
            ids: vec![Raster { width: 4, height: 1, data: vec![1, 2, 2, 0] }],
        }
    }

    #[test]
    fn each_moving_object_is_scored_on_its_own_pixels_in_the_true_units() {
        let truth = truth();
        // Rendered in a world half the size: 1.0 there is 2.0 m.
        let rendered = ScalarRaster { width: 4, height: 1, data: vec![9.0, 1.0, 1.1, 9.0] };
        let errors = truth.depth_errors_pct(&[&rendered], 2.0);
        assert_eq!(errors.len(), 2);
        // Object 2: errors 0% and 10%, median 5%; object 1 (not moving) and the far pixels not.
        assert!((errors[0] - 5.0).abs() < 1e-4, "{errors:?}");
        assert!(errors[1].is_nan(), "object 3 is not seen: {errors:?}");
    }

    #[test]
    fn a_pixel_without_rendered_depth_counts_as_wrong() {
        let rendered = ScalarRaster { width: 4, height: 1, data: vec![5.0, f32::INFINITY, f32::NAN, 4.0] };
        assert!((truth().depth_errors_pct(&[&rendered], 1.0)[0] - 100.0).abs() < 1e-9);
    }
}
