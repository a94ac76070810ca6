//! The fixture of `dynview-web`'s browser tests (`wasm-pack test --headless --chrome
//! crates/dynview-web`), made by this crate's build script on the host, so the tests need no
//! preparation step and no committed renders that could go stale:
//!
//! - `scene/...`: a small synthetic scene package (`dynview synth` with [`CAMERAS`] cameras,
//!   [`FRAMES`] frames of [`WIDTH`] x [`HEIGHT`], no videos);
//! - `camera_path.json`: its held-out camera path;
//! - `native/<i:05>.png`: the first [`NATIVE_FRAMES`] frames of that path rendered by the
//!   host's `dynview-core` as `dynview render` does (the CPU streaming renderer with the
//!   default parameters), the reference the wasm and browser-GPU renders must equal.
//!
//! The build script reruns when `dynview-core` or `dynview-synth` change (they are its
//! build-dependencies), so the native renders always come from the code under test. The files
//! are embedded with `include_bytes!` and need the `generate` feature; without it [`FILES`] is
//! empty and nothing of dynview is compiled for the host.
#![no_std]

include!("config.rs");

#[cfg(feature = "generate")]
include!(concat!(env!("OUT_DIR"), "/files.rs"));

/// The fixture's files as `(path, bytes)`, paths relative and `/`-separated, sorted.
#[cfg(not(feature = "generate"))]
pub const FILES: &[(&str, &[u8])] = &[];

/// The bytes of the fixture file `path`, if there is one.
pub fn file(path: &str) -> Option<&'static [u8]> {
    FILES.iter().find(|(p, _)| *p == path).map(|(_, bytes)| *bytes)
}
