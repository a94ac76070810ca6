//! Native VP9 encoding and decoding of a package's videos through the `ffmpeg` program
//! (libvpx-vp9 to encode, ffmpeg's bit-exact VP9 decoder to decode). Frames go in and come out
//! as raw 4:2:0 planes; the conversion to and from RGB is [`super::yuv`]'s, the same in the
//! browser.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};

use super::error::{SceneError, SceneResult};
use super::video::{CameraFrames, IvfHeader, scan_ivf};
use super::yuv::{PlaneLayout, Yuv420, frame_bytes};

/// How a package's videos are encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct VideoSettings {
    /// libvpx-vp9 constant-quality level, 0 (best) to 63.
    pub crf: u32,
    /// At most this many frames from one keyframe to the next.
    pub keyframe_interval: u32,
}

/// The default quality level: 43 dB PSNR against the input frames on the real Panoptic arc
/// (640x360), 1.9 KB a frame against 29 KB as JPEG at quality 92.
pub const DEFAULT_CRF: u32 = 36;
/// The default keyframe interval: showing any frame after a scrub decodes at most this many.
pub const DEFAULT_KEYFRAME_INTERVAL: u32 = 30;

impl Default for VideoSettings {
    fn default() -> Self {
        Self { crf: DEFAULT_CRF, keyframe_interval: DEFAULT_KEYFRAME_INTERVAL }
    }
}

fn spawn_failed(file: &Path, e: std::io::Error) -> SceneError {
    let problem = if e.kind() == std::io::ErrorKind::NotFound {
        "the `ffmpeg` program is not installed: video frames need it (`apt-get install ffmpeg`), or write image frames (`--frames-as jpeg`)"
            .to_string()
    } else {
        format!("could not start ffmpeg: {e}")
    };
    SceneError::invalid(file.display().to_string(), "(video)", problem)
}

fn ffmpeg_failed(file: &Path, what: &str, stderr: &[u8]) -> SceneError {
    let text = String::from_utf8_lossy(stderr);
    let last = text.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no message");
    SceneError::invalid(file.display().to_string(), "(video)", format!("ffmpeg failed to {what}: {last}"))
}

/// One camera's video being written: frames go to an `ffmpeg` process in time order.
#[derive(Debug)]
pub struct VideoEncoder {
    child: Child,
    stdin: Option<ChildStdin>,
    path: PathBuf,
    width: u32,
    height: u32,
    frames_written: u32,
}

impl VideoEncoder {
    /// Starts encoding a `width x height` stream at `fps` into the IVF file `path`.
    pub fn start(path: &Path, width: u32, height: u32, fps: f64, settings: VideoSettings) -> SceneResult<Self> {
        let mut child = Command::new("ffmpeg")
            .args(["-nostdin", "-v", "error", "-y", "-f", "rawvideo", "-pix_fmt", "yuv420p", "-color_range", "pc"])
            .args(["-video_size", &format!("{width}x{height}"), "-framerate", &format!("{fps}"), "-i", "pipe:0"])
            .args(["-c:v", "libvpx-vp9", "-crf", &settings.crf.to_string(), "-b:v", "0"])
            .args(["-g", &settings.keyframe_interval.to_string()])
            // One shown frame per IVF frame: no hidden alternate reference frames, no look-ahead.
            .args(["-auto-alt-ref", "0", "-lag-in-frames", "0", "-deadline", "good", "-cpu-used", "4", "-row-mt", "1"])
            .args(["-color_range", "pc", "-colorspace", "bt470bg", "-f", "ivf"])
            .arg(path)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| spawn_failed(path, e))?;
        let stdin = child.stdin.take();
        Ok(Self { child, stdin, path: path.to_path_buf(), width, height, frames_written: 0 })
    }

    /// Frames written so far (the next frame written is frame `frames_written()`).
    pub fn frames_written(&self) -> u32 {
        self.frames_written
    }

    /// Appends the next frame.
    pub fn push(&mut self, frame: &Yuv420) -> SceneResult<()> {
        if (frame.width, frame.height) != (self.width, self.height) {
            return Err(SceneError::invalid(
                self.path.display().to_string(),
                "(frame size)",
                format!("{}x{}, expected {}x{}", frame.width, frame.height, self.width, self.height),
            ));
        }
        let Some(stdin) = self.stdin.as_mut() else {
            return Err(SceneError::invalid(self.path.display().to_string(), "(video)", "the encoder was already finished"));
        };
        if let Err(e) = stdin.write_all(&frame.to_i420_bytes()) {
            // ffmpeg stopped: its message says why.
            let mut stderr = Vec::new();
            self.stdin = None;
            if let Some(mut pipe) = self.child.stderr.take() {
                let _ = pipe.read_to_end(&mut stderr);
            }
            let _ = self.child.wait();
            return Err(if stderr.is_empty() { SceneError::io(&self.path, e) } else { ffmpeg_failed(&self.path, "encode", &stderr) });
        }
        self.frames_written += 1;
        Ok(())
    }

    /// Ends the stream, waits for ffmpeg and returns the written file's frames (checking they
    /// are one shown VP9 frame each, as many as were pushed).
    pub fn finish(mut self) -> SceneResult<CameraFrames> {
        drop(self.stdin.take());
        let mut stderr = Vec::new();
        if let Some(mut pipe) = self.child.stderr.take() {
            pipe.read_to_end(&mut stderr).map_err(|e| SceneError::io(&self.path, e))?;
        }
        let status = self.child.wait().map_err(|e| SceneError::io(&self.path, e))?;
        if !status.success() {
            return Err(ffmpeg_failed(&self.path, "encode", &stderr));
        }
        let bytes = std::fs::read(&self.path).map_err(|e| SceneError::io(&self.path, e))?;
        let frames = scan_ivf(&bytes, self.width, self.height, &self.path.display().to_string())?;
        if frames.frames.len() != self.frames_written as usize {
            return Err(SceneError::invalid(
                self.path.display().to_string(),
                "(video)",
                format!("{} frames in the stream, {} written", frames.frames.len(), self.frames_written),
            ));
        }
        Ok(frames)
    }
}

impl Drop for VideoEncoder {
    fn drop(&mut self) {
        // An abandoned write: stop ffmpeg rather than leave it waiting on its input.
        if self.stdin.take().is_some() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Decodes consecutive VP9 frames (`payloads`, the first a keyframe) of a `width x height`
/// stream and returns the decoded frames from the `keep_from`-th on. `file` names the stream
/// in errors.
pub fn decode_vp9(width: u32, height: u32, payloads: &[&[u8]], keep_from: usize, file: &Path) -> SceneResult<Vec<Yuv420>> {
    let (w, h) = (u16::try_from(width), u16::try_from(height));
    let (Ok(w), Ok(h)) = (w, h) else {
        return Err(SceneError::invalid(file.display().to_string(), "(frame size)", "IVF streams are at most 65535 px a side"));
    };
    let mut ivf = IvfHeader::vp9(w, h, payloads.len() as u32).to_vec();
    for (i, p) in payloads.iter().enumerate() {
        ivf.extend_from_slice(&(p.len() as u32).to_le_bytes());
        ivf.extend_from_slice(&(i as u64).to_le_bytes());
        ivf.extend_from_slice(p);
    }
    let mut child = Command::new("ffmpeg")
        .args(["-nostdin", "-v", "error", "-f", "ivf", "-i", "pipe:0", "-fps_mode", "passthrough"])
        .args(["-f", "rawvideo", "-pix_fmt", "yuv420p", "pipe:1"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| spawn_failed(file, e))?;
    let (mut stdin, mut stdout, mut stderr) = (child.stdin.take(), child.stdout.take(), child.stderr.take());
    let size = frame_bytes(width, height);
    let mut frames = Vec::new();
    let mut errors = Vec::new();
    let read = std::thread::scope(|scope| {
        scope.spawn(move || {
            // A write error means ffmpeg stopped early; its stderr says why.
            let _ = stdin.as_mut().map(|s| s.write_all(&ivf));
            drop(stdin);
        });
        let messages = scope.spawn(move || {
            let mut bytes = Vec::new();
            let _ = stderr.as_mut().map(|s| s.read_to_end(&mut bytes));
            bytes
        });
        let mut result = Ok(());
        if let Some(out) = stdout.as_mut() {
            let mut buffer = vec![0u8; size];
            let mut index = 0;
            loop {
                match read_full(out, &mut buffer) {
                    Ok(true) => {}
                    Ok(false) => break,
                    Err(e) => {
                        result = Err(e);
                        break;
                    }
                }
                // The buffer has the size of a frame, so it always converts (the count check
                // below would catch a frame that did not).
                if let Some(frame) = (index >= keep_from).then(|| Yuv420::from_bytes(width, height, PlaneLayout::I420, &buffer)).flatten() {
                    frames.push(frame);
                }
                index += 1;
                if index > payloads.len() {
                    result = Err(std::io::Error::other("ffmpeg decoded more frames than it was given"));
                    break;
                }
            }
        }
        errors = messages.join().unwrap_or_default();
        result
    });
    drop(stdout); // ffmpeg may still be writing after an error: let it stop
    let status = child.wait().map_err(|e| SceneError::io(file, e))?;
    read.map_err(|e| SceneError::io(file, e))?;
    if !status.success() {
        return Err(ffmpeg_failed(file, "decode", &errors));
    }
    let wanted = payloads.len().saturating_sub(keep_from);
    if frames.len() != wanted {
        return Err(SceneError::invalid(
            file.display().to_string(),
            "(video)",
            format!(
                "{} frames decoded from {} VP9 frames, expected {wanted}",
                frames.len() + keep_from.min(payloads.len()),
                payloads.len()
            ),
        ));
    }
    Ok(frames)
}

/// Fills `buffer` from `reader`: `Ok(false)` at a clean end of stream before any byte.
fn read_full(reader: &mut impl Read, buffer: &mut [u8]) -> std::io::Result<bool> {
    let mut filled = 0;
    while filled < buffer.len() {
        match reader.read(&mut buffer[filled..])? {
            0 if filled == 0 => return Ok(false),
            0 => return Err(std::io::Error::new(std::io::ErrorKind::UnexpectedEof, "ffmpeg's output ended inside a frame")),
            n => filled += n,
        }
    }
    Ok(true)
}
