//! The sparse consistency filter on the GPU against the CPU's `SplatMaps::drop_inconsistent`,
//! on maps where the surround test decides: a sparse near disc in front of a dense far wall.

use dynview_core::raster::Raster;
use dynview_core::render::sparse::SplatMaps;
use dynview_gpu::{ConsistencyKernels, GpuContext, GpuImage, GpuSplat};

const W: usize = 96;
const H: usize = 64;
/// The near disc: centre, radius and the spacing of its samples (pixels).
const DISC: (f32, f32, f32) = (40.0, 30.0, 16.0);
const DISC_SPACING: usize = 5;
/// Far samples that float alone in front of the wall: no sample of their depth within 8 px.
const OUTLIERS: [(usize, usize); 3] = [(80, 10), (85, 50), (10, 55)];

fn context() -> GpuContext {
    GpuContext::new_blocking().unwrap_or_else(|e| panic!("{e}"))
}

fn distance_to_disc_centre(x: usize, y: usize) -> f32 {
    ((x as f32 - DISC.0).powi(2) + (y as f32 - DISC.1).powi(2)).sqrt()
}

/// A wall at depth 5 sampled at 3 pixels of 4, a disc at depth 2 sampled every
/// [`DISC_SPACING`] pixels (with the wall's samples between), and [`OUTLIERS`] at depth 1.
fn maps() -> SplatMaps {
    let mut depth = Raster::filled(W, H, f32::INFINITY);
    for y in 0..H {
        for x in 0..W {
            if (x * 7 + y * 3) % 4 != 0 {
                depth.data[y * W + x] = 5.0 + 0.01 * ((x * 13 + y * 5) % 7) as f32;
            }
            if x % DISC_SPACING == 0 && y % DISC_SPACING == 0 && distance_to_disc_centre(x, y) <= DISC.2 {
                depth.data[y * W + x] = 2.0;
            }
        }
    }
    for (x, y) in OUTLIERS {
        depth.data[y * W + x] = 1.0;
    }
    let mask = depth.map(|d| if d.is_finite() { 1.0 } else { 0.0 });
    let color = depth.map(|d| [d / 5.0, 0.5, 0.25]);
    SplatMaps { depth, color, mask }
}

fn upload(ctx: &GpuContext, maps: &SplatMaps) -> GpuSplat {
    GpuSplat {
        depth: GpuImage::upload(ctx, &maps.depth.data, W, H, 1).unwrap(),
        color: GpuImage::upload(ctx, maps.color.data.as_flattened(), W, H, 3).unwrap(),
        mask: GpuImage::upload(ctx, &maps.mask.data, W, H, 1).unwrap(),
    }
}

#[test]
fn the_surround_test_hides_a_dense_wall_behind_a_sparse_disc_on_the_gpu_as_on_the_cpu() {
    let ctx = context();
    let kernels = ConsistencyKernels::new(&ctx);
    let before = maps();
    for surround in [0, 8] {
        let mut cpu = before.clone();
        cpu.drop_inconsistent(0.03, None, surround);
        let gpu = upload(&ctx, &before);
        let counters = kernels.drop_inconsistent(&ctx, &gpu, 0.03, surround).unwrap();
        assert_eq!(gpu.mask.download(&ctx).unwrap(), cpu.mask.data, "surround {surround}: mask");
        assert_eq!(gpu.depth.download(&ctx).unwrap(), cpu.depth.data, "surround {surround}: depth");
        assert_eq!(counters.download(&ctx).unwrap()[1].to_bits() as usize, cpu.covered(), "surround {surround}: count");

        let kept = |x: usize, y: usize| cpu.mask.data[y * W + x] > 0.0;
        let (mut disc, mut disc_kept, mut wall_inside, mut wall_inside_kept, mut wall_outside, mut wall_outside_kept) = (0, 0, 0, 0, 0, 0);
        for y in 0..H {
            for x in 0..W {
                let d = before.depth.data[y * W + x];
                let r = distance_to_disc_centre(x, y);
                if d == 2.0 {
                    disc += 1;
                    disc_kept += usize::from(kept(x, y));
                } else if (5.0..f32::INFINITY).contains(&d) && r < DISC.2 - DISC_SPACING as f32 {
                    wall_inside += 1;
                    wall_inside_kept += usize::from(kept(x, y));
                } else if (5.0..f32::INFINITY).contains(&d) && r > DISC.2 + 2.0 {
                    wall_outside += 1;
                    wall_outside_kept += usize::from(kept(x, y));
                }
            }
        }
        assert!(OUTLIERS.iter().all(|&(x, y)| !kept(x, y)), "surround {surround}: the floating samples are dropped");
        assert_eq!(wall_outside_kept, wall_outside, "surround {surround}: the wall beside the disc stays");
        if surround == 0 {
            // The window (half the mean spacing: 1 px) neither reaches the disc's neighbours nor
            // across its gaps: its samples are taken for outliers and the wall shows through.
            assert_eq!(disc_kept, 0, "without the surround test the disc is dropped");
            assert!(wall_inside_kept > wall_inside / 2, "without the surround test the wall shows through");
        } else {
            assert_eq!(disc_kept, disc, "the disc's samples support each other across its gaps");
            assert_eq!(wall_inside_kept, 0, "the wall behind the disc is hidden");
        }
    }
}
