//! Shared helpers of the integration tests: small synthetic events generated once per test
//! binary.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use dynview_synth::SynthConfig;

/// A small event: 4 cameras, 4 frames of 192x108, no videos.
pub fn small_config() -> SynthConfig {
    SynthConfig { cameras: 4, frames: 4, width: 192, height: 108, videos: false, point_fraction: 0.02, ..SynthConfig::default() }
}

/// Generates the small event once per test binary and returns its folder.
pub fn small_event() -> &'static Path {
    static EVENT: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    let (_, path) = EVENT.get_or_init(|| {
        let dir = tempfile::tempdir().expect("temp dir");
        let out = dir.path().join("event");
        dynview_synth::generate(&small_config(), &out, &|_, _, _| {}).expect("synth");
        (dir, out)
    });
    path
}

/// Loads an 8-bit PNG as a color raster.
pub fn load_rgb(path: &Path) -> dynview_core::RgbRaster {
    let image = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    dynview_core::RgbRaster::from_rgb8(&image.to_rgb8())
}
