//! Makes the browser-test fixture on the host (see `src/lib.rs`): a synthetic event with
//! `dynview-synth`, the native renders of its held-out path with `dynview-core`, and
//! `$OUT_DIR/files.rs`, which embeds the files the tests read.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-changed=src/config.rs");
    #[cfg(feature = "generate")]
    generate::files_rs(std::path::Path::new(&std::env::var("OUT_DIR")?))?;
    Ok(())
}

#[cfg(feature = "generate")]
mod generate {
    use std::error::Error;
    use std::fmt::Write as _;
    use std::path::{Path, PathBuf};

    use dynview_core::fsutil::write_atomic;
    use dynview_core::render::{RenderHooks, RenderParams, StreamingRenderer};
    use dynview_core::scene::ScenePackage;
    use dynview_interchange::camera_path::parse_path;
    use dynview_synth::SynthConfig;

    include!("src/config.rs");

    /// Makes the fixture under `out` and writes `out/files.rs`.
    pub fn files_rs(out: &Path) -> Result<(), Box<dyn Error>> {
        let event = out.join("event");
        // As `dynview synth --cameras CAMERAS --frames FRAMES --width WIDTH --height HEIGHT --no-video`.
        let config =
            SynthConfig { cameras: CAMERAS, frames: FRAMES, width: WIDTH, height: HEIGHT, videos: false, ..SynthConfig::default() };
        dynview_synth::generate(&config, &event, &|_, _, _| {})?;
        let native = out.join("native");
        render_natively(&event.join("scene"), &event.join("camera_path.json"), &native)?;

        let mut files = Vec::new();
        walk(&event.join("scene"), "scene", &mut files)?;
        files.push(("camera_path.json".to_owned(), event.join("camera_path.json")));
        walk(&native, "native", &mut files)?;
        files.sort();
        let mut rs = String::from("/// The fixture's files as `(path, bytes)`, paths relative and `/`-separated, sorted.\n");
        rs.push_str("pub const FILES: &[(&str, &[u8])] = &[\n");
        for (name, path) in &files {
            let path = path.to_str().ok_or_else(|| format!("{}: not UTF-8", path.display()))?;
            writeln!(rs, "    ({name:?}, include_bytes!({path:?})),")?;
        }
        rs.push_str("];\n");
        write_atomic(&out.join("files.rs"), rs.as_bytes())?;
        Ok(())
    }

    /// Renders the first `NATIVE_FRAMES` frames of the camera path `path` through `scene` into
    /// `out/<i:05>.png` as `dynview render` does: the CPU streaming renderer with the default
    /// parameters, the temporal terms carried from frame to frame, dropped on a jump in time.
    fn render_natively(scene: &Path, path: &Path, out: &Path) -> Result<(), Box<dyn Error>> {
        let params = RenderParams::default();
        let package = ScenePackage::open(scene)?;
        let frames = parse_path(&std::fs::read(path)?, &path.display().to_string(), None)?;
        let steps = package.time_step_count();
        let mut renderer = StreamingRenderer::new();
        let mut last_step: Option<u32> = None;
        std::fs::create_dir_all(out)?;
        for (i, frame) in frames.iter().take(NATIVE_FRAMES as usize).enumerate() {
            let t = frame.time.time_step(steps);
            if last_step.is_some_and(|lt| lt.abs_diff(t) > 1) {
                renderer.jump();
            }
            last_step = Some(t);
            let inputs = package.time_step_inputs(t, params.levels)?;
            let output = renderer.render(&params, &frame.camera, &inputs, &mut RenderHooks::default())?;
            let mut png = Vec::new();
            output.color.to_rgb8().write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
            write_atomic(&out.join(format!("{i:05}.png")), &png)?;
        }
        Ok(())
    }

    /// Every file under `dir` as (`prefix/relative/path`, full path).
    fn walk(dir: &Path, prefix: &str, files: &mut Vec<(String, PathBuf)>) -> Result<(), Box<dyn Error>> {
        for entry in std::fs::read_dir(dir)? {
            let entry = entry?;
            let name = format!("{prefix}/{}", entry.file_name().to_string_lossy());
            if entry.file_type()?.is_dir() {
                walk(&entry.path(), &name, files)?;
            } else {
                files.push((name, entry.path()));
            }
        }
        Ok(())
    }
}
