//! Frames as video (format v2): one VP9 stream per camera in an IVF file, `frames/<camera>.ivf`,
//! and one index, `frames.idx`, that gives every frame's byte range and whether it is a
//! keyframe. Frame `t` of a camera's stream is its frame at time step `t`; every IVF frame is
//! one shown frame. A reader fetches the frames from the keyframe at or before `t` to `t` in
//! one byte range and decodes them in order.
//!
//! `frames.idx` (all integers little-endian):
//!
//! | offset | size | field |
//! | --- | --- | --- |
//! | 0 | 8 | magic `DVFRMIDX` |
//! | 8 | 4 | `version`, u32 = 1 |
//! | 12 | 4 | `camera_count`, u32 |
//! | 16 | 4 | `step_count`, u32 |
//! | 20 | 4 | CRC-32 of bytes 0..20 followed by bytes 24.. |
//! | 24 | per camera | `ivf_byte_length` (u64), then `step_count` u32: bit 31 set for a keyframe, bits 0..31 the frame's payload length |

use super::error::{SceneError, SceneResult};
use super::limits::{MAX_CAMERAS, MAX_FRAME_FILE_BYTES, MAX_KEYFRAME_INTERVAL, MAX_TIME_STEPS};

/// Magic bytes at the start of `frames.idx`.
pub const INDEX_MAGIC: &[u8; 8] = b"DVFRMIDX";
/// Version of the `frames.idx` layout.
pub const INDEX_VERSION: u32 = 1;
/// Bytes before the per-camera blocks of `frames.idx`.
pub const INDEX_HEADER_BYTES: usize = 24;
/// Bytes of an IVF file header.
pub const IVF_HEADER_BYTES: u64 = 32;
/// Bytes of the header before each IVF frame's payload.
pub const IVF_FRAME_HEADER_BYTES: u64 = 12;
/// The WebCodecs codec string of the streams (VP9 profile 0, level 1.0, 8-bit).
pub const WEBCODECS_CODEC: &str = "vp09.00.10.08";
const KEY_BIT: u32 = 1 << 31;

/// Bytes of `frames.idx` for `cameras` cameras and `steps` time steps.
pub fn index_byte_length(cameras: usize, steps: u32) -> u64 {
    INDEX_HEADER_BYTES as u64 + cameras as u64 * (8 + 4 * u64::from(steps))
}

/// One frame of a camera's stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameEntry {
    /// Offset of the frame's payload in the IVF file (after its 12-byte frame header).
    pub offset: u64,
    /// Payload length in bytes.
    pub length: u32,
    /// Whether the frame is a keyframe (decodable on its own).
    pub key: bool,
}

/// The frames of one camera's stream.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CameraFrames {
    /// Exact size of the camera's IVF file.
    pub ivf_byte_length: u64,
    /// One entry per time step.
    pub frames: Vec<FrameEntry>,
}

/// A contiguous piece of a camera's IVF file holding frames `first..=last`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameSpan {
    /// The first frame (a keyframe).
    pub first: u32,
    /// The last frame (the one wanted).
    pub last: u32,
    /// Byte range `[start, end)` in the IVF file, frame headers included.
    pub bytes: (u64, u64),
}

impl CameraFrames {
    /// The keyframe at or before `t` (frame 0 always is one).
    pub fn keyframe_at_or_before(&self, t: u32) -> u32 {
        (0..=t).rev().find(|&k| self.frames[k as usize].key).unwrap_or(0)
    }

    /// The span to decode to show frame `t`, starting at its keyframe, or at `after + 1` when
    /// the decoder already holds frame `after` of the same group (`after < t`).
    pub fn span_to(&self, t: u32, after: Option<u32>) -> FrameSpan {
        let key = self.keyframe_at_or_before(t);
        let first = match after {
            Some(a) if a >= key && a < t => a + 1,
            _ => key,
        };
        let start = self.frames[first as usize].offset - IVF_FRAME_HEADER_BYTES;
        let last = self.frames[t as usize];
        FrameSpan { first, last: t, bytes: (start, last.offset + u64::from(last.length)) }
    }

    /// Cuts the payloads of `span`'s frames out of its bytes, checking each IVF frame header
    /// against the index. `file` names the IVF file in errors.
    pub fn payloads<'a>(&self, span: &FrameSpan, bytes: &'a [u8], file: &str) -> SceneResult<Vec<&'a [u8]>> {
        if bytes.len() as u64 != span.bytes.1 - span.bytes.0 {
            return Err(SceneError::invalid(
                file,
                "(bytes)",
                format!("{} bytes read, expected {}", bytes.len(), span.bytes.1 - span.bytes.0),
            ));
        }
        let mut out = Vec::with_capacity((span.last - span.first + 1) as usize);
        for t in span.first..=span.last {
            let entry = self.frames[t as usize];
            let header = (entry.offset - IVF_FRAME_HEADER_BYTES - span.bytes.0) as usize;
            let size = u32::from_le_bytes(bytes[header..header + 4].try_into().unwrap_or_default());
            if size != entry.length {
                return Err(SceneError::invalid(
                    file,
                    format!("frame {t}"),
                    format!("IVF frame header says {size} bytes, frames.idx {}", entry.length),
                ));
            }
            let payload = &bytes[header + IVF_FRAME_HEADER_BYTES as usize..header + IVF_FRAME_HEADER_BYTES as usize + size as usize];
            let kind = Vp9FrameKind::parse(payload);
            if kind != Some(Vp9FrameKind { key: entry.key, shown: true }) {
                return Err(SceneError::invalid(
                    file,
                    format!("frame {t}"),
                    format!("not a shown VP9 frame of the kind frames.idx says ({kind:?})"),
                ));
            }
            out.push(payload);
        }
        Ok(out)
    }
}

/// The parsed `frames.idx`: every camera's frames.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrameIndex {
    /// One per camera, in manifest order.
    pub cameras: Vec<CameraFrames>,
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap_or_default())
}

impl FrameIndex {
    /// Parses and validates `frames.idx` for a package of `cameras` cameras and `steps` time
    /// steps. `file` names the file in errors.
    pub fn parse(bytes: &[u8], cameras: usize, steps: u32, file: &str) -> SceneResult<Self> {
        let bad = |field: &str, problem: String| SceneError::invalid(file, field, problem);
        if bytes.len() < INDEX_HEADER_BYTES {
            return Err(bad("(header)", format!("{} bytes, shorter than the {INDEX_HEADER_BYTES}-byte header", bytes.len())));
        }
        if &bytes[..8] != INDEX_MAGIC {
            return Err(bad("magic", "not a dynview frame index (magic DVFRMIDX)".into()));
        }
        let version = u32_at(bytes, 8);
        if version != INDEX_VERSION {
            return Err(bad("version", format!("unsupported version {version} (this reader knows {INDEX_VERSION})")));
        }
        let (camera_count, step_count) = (u32_at(bytes, 12) as usize, u32_at(bytes, 16));
        if camera_count != cameras || camera_count > MAX_CAMERAS {
            return Err(bad("camera_count", format!("{camera_count} cameras, scene.json has {cameras}")));
        }
        if step_count != steps || step_count > MAX_TIME_STEPS {
            return Err(bad("step_count", format!("{step_count} steps, scene.json has time_step_count {steps}")));
        }
        let expected = index_byte_length(cameras, steps);
        if bytes.len() as u64 != expected {
            return Err(bad("(file)", format!("{} bytes, expected {expected} for {cameras} cameras and {steps} steps", bytes.len())));
        }
        let (stored, computed) = (u32_at(bytes, 20), checksum(bytes));
        if stored != computed {
            return Err(SceneError::Checksum { file: file.to_owned(), field: "crc32".into(), stored, computed });
        }
        let mut out = Vec::with_capacity(cameras);
        let mut at = INDEX_HEADER_BYTES;
        for c in 0..cameras {
            let ivf_byte_length = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap_or_default());
            at += 8;
            let mut frames = Vec::with_capacity(steps as usize);
            let mut offset = IVF_HEADER_BYTES;
            let mut since_key = 0u32;
            let mut group_start = IVF_HEADER_BYTES;
            for t in 0..steps as usize {
                let word = u32_at(bytes, at);
                at += 4;
                let (key, length) = (word & KEY_BIT != 0, word & !KEY_BIT);
                let field = format!("cameras[{c}].frames[{t}]");
                if length == 0 || u64::from(length) > MAX_FRAME_FILE_BYTES {
                    return Err(bad(&field, format!("payload length {length} is not in 1..={MAX_FRAME_FILE_BYTES}")));
                }
                if t == 0 && !key {
                    return Err(bad(&field, "the first frame must be a keyframe".into()));
                }
                since_key = if key { 0 } else { since_key + 1 };
                if since_key >= MAX_KEYFRAME_INTERVAL {
                    return Err(bad(&field, format!("more than {MAX_KEYFRAME_INTERVAL} frames since the last keyframe")));
                }
                if key {
                    group_start = offset;
                }
                offset += IVF_FRAME_HEADER_BYTES;
                frames.push(FrameEntry { offset, length, key });
                offset += u64::from(length);
                // A reader fetches a group's frames up to the one it shows in one range.
                if offset - group_start > MAX_FRAME_FILE_BYTES {
                    return Err(bad(&field, format!("more than {MAX_FRAME_FILE_BYTES} bytes since the last keyframe")));
                }
            }
            if offset != ivf_byte_length {
                return Err(bad(
                    &format!("cameras[{c}].ivf_byte_length"),
                    format!("{ivf_byte_length}, but the frames end at byte {offset}"),
                ));
            }
            out.push(CameraFrames { ivf_byte_length, frames });
        }
        Ok(Self { cameras: out })
    }

    /// Encodes the index (the inverse of [`FrameIndex::parse`]).
    pub fn encode(&self) -> Vec<u8> {
        let steps = self.cameras.first().map_or(0, |c| c.frames.len());
        let mut out = Vec::with_capacity(index_byte_length(self.cameras.len(), steps as u32) as usize);
        out.extend_from_slice(INDEX_MAGIC);
        out.extend_from_slice(&INDEX_VERSION.to_le_bytes());
        out.extend_from_slice(&(self.cameras.len() as u32).to_le_bytes());
        out.extend_from_slice(&(steps as u32).to_le_bytes());
        out.extend_from_slice(&[0; 4]);
        for camera in &self.cameras {
            out.extend_from_slice(&camera.ivf_byte_length.to_le_bytes());
            for f in &camera.frames {
                out.extend_from_slice(&(f.length | if f.key { KEY_BIT } else { 0 }).to_le_bytes());
            }
        }
        let crc = checksum(&out);
        out[20..24].copy_from_slice(&crc.to_le_bytes());
        out
    }
}

fn checksum(bytes: &[u8]) -> u32 {
    let mut hasher = crc32fast::Hasher::new();
    hasher.update(&bytes[..20]);
    hasher.update(&bytes[24..]);
    hasher.finalize()
}

/// What the first byte of a VP9 frame says about it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Vp9FrameKind {
    /// A keyframe.
    pub key: bool,
    /// Shown (not a hidden reference frame, not a repeat of an earlier one).
    pub shown: bool,
}

impl Vp9FrameKind {
    /// Reads the uncompressed header's first bits (profile 0 to 2 layout); `None` when the
    /// payload is empty or not a VP9 frame.
    pub fn parse(payload: &[u8]) -> Option<Self> {
        let b = *payload.first()?;
        if b >> 6 != 0b10 {
            return None; // frame_marker
        }
        let profile = ((b >> 5) & 1) | (((b >> 4) & 1) << 1);
        // Profile 3 has a reserved bit before show_existing_frame.
        let b = if profile == 3 { b << 1 } else { b };
        let show_existing = (b >> 3) & 1 == 1;
        if show_existing {
            return Some(Self { key: false, shown: false });
        }
        Some(Self { key: (b >> 2) & 1 == 0, shown: (b >> 1) & 1 == 1 })
    }
}

/// The fields of an IVF file header that a reader checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IvfHeader {
    /// The codec's four characters (`VP90`).
    pub fourcc: [u8; 4],
    /// Frame width in pixels.
    pub width: u16,
    /// Frame height in pixels.
    pub height: u16,
    /// Number of frames the header claims.
    pub frame_count: u32,
}

impl IvfHeader {
    /// Parses the 32-byte header; `None` when it is not one.
    pub fn parse(bytes: &[u8]) -> Option<Self> {
        let b = bytes.get(..IVF_HEADER_BYTES as usize)?;
        if &b[..4] != b"DKIF" || u16::from_le_bytes([b[6], b[7]]) != IVF_HEADER_BYTES as u16 {
            return None;
        }
        Some(Self {
            fourcc: [b[8], b[9], b[10], b[11]],
            width: u16::from_le_bytes([b[12], b[13]]),
            height: u16::from_le_bytes([b[14], b[15]]),
            frame_count: u32_at(b, 24),
        })
    }

    /// A header for a VP9 stream of `frame_count` frames at `fps`.
    pub fn vp9(width: u16, height: u16, frame_count: u32) -> [u8; 32] {
        let mut out = [0u8; 32];
        out[..4].copy_from_slice(b"DKIF");
        out[6..8].copy_from_slice(&(IVF_HEADER_BYTES as u16).to_le_bytes());
        out[8..12].copy_from_slice(b"VP90");
        out[12..14].copy_from_slice(&width.to_le_bytes());
        out[14..16].copy_from_slice(&height.to_le_bytes());
        out[16..20].copy_from_slice(&30u32.to_le_bytes());
        out[20..24].copy_from_slice(&1u32.to_le_bytes());
        out[24..28].copy_from_slice(&frame_count.to_le_bytes());
        out
    }
}

/// Cuts an IVF file into its frames' entries (checking every frame is a shown VP9 frame);
/// `file` names it in errors. The index of a freshly written stream comes from here.
pub fn scan_ivf(bytes: &[u8], width: u32, height: u32, file: &str) -> SceneResult<CameraFrames> {
    let bad = |field: String, problem: String| SceneError::invalid(file, field, problem);
    let header = IvfHeader::parse(bytes).ok_or_else(|| bad("(header)".into(), "not an IVF file".into()))?;
    if &header.fourcc != b"VP90" {
        return Err(bad("fourcc".into(), format!("{:?}, expected VP90", String::from_utf8_lossy(&header.fourcc))));
    }
    if (u32::from(header.width), u32::from(header.height)) != (width, height) {
        return Err(bad("(frame size)".into(), format!("{}x{}, expected {width}x{height}", header.width, header.height)));
    }
    let mut frames = Vec::new();
    let mut at = IVF_HEADER_BYTES as usize;
    while at < bytes.len() {
        let t = frames.len();
        let Some(size) = bytes.get(at..at + 4).map(|b| u32::from_le_bytes(b.try_into().unwrap_or_default())) else {
            return Err(bad(format!("frame {t}"), "truncated frame header".into()));
        };
        let offset = (at + IVF_FRAME_HEADER_BYTES as usize) as u64;
        let payload = bytes
            .get(offset as usize..offset as usize + size as usize)
            .ok_or_else(|| bad(format!("frame {t}"), "truncated payload".into()))?;
        let kind = Vp9FrameKind::parse(payload).ok_or_else(|| bad(format!("frame {t}"), "not a VP9 frame".into()))?;
        if !kind.shown {
            return Err(bad(format!("frame {t}"), "a hidden or repeated frame: streams must be one shown frame per IVF frame".into()));
        }
        frames.push(FrameEntry { offset, length: size, key: kind.key });
        at = offset as usize + size as usize;
    }
    Ok(CameraFrames { ivf_byte_length: bytes.len() as u64, frames })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frames(keys: &[bool], lengths: &[u32]) -> CameraFrames {
        let mut offset = IVF_HEADER_BYTES;
        let frames = keys
            .iter()
            .zip(lengths)
            .map(|(&key, &length)| {
                offset += IVF_FRAME_HEADER_BYTES;
                let e = FrameEntry { offset, length, key };
                offset += u64::from(length);
                e
            })
            .collect();
        CameraFrames { ivf_byte_length: offset, frames }
    }

    fn index() -> FrameIndex {
        FrameIndex { cameras: vec![frames(&[true, false, false, true, false], &[100, 5, 6, 90, 7]), frames(&[true; 5], &[1, 2, 3, 4, 5])] }
    }

    #[test]
    fn index_round_trips_and_spans_start_at_keyframes() {
        let idx = index();
        let bytes = idx.encode();
        assert_eq!(bytes.len() as u64, index_byte_length(2, 5));
        let back = FrameIndex::parse(&bytes, 2, 5, "frames.idx").unwrap();
        assert_eq!(back, idx);
        let cam = &back.cameras[0];
        assert_eq!(cam.keyframe_at_or_before(2), 0);
        assert_eq!(cam.keyframe_at_or_before(4), 3);
        let span = cam.span_to(2, None);
        assert_eq!((span.first, span.last), (0, 2));
        assert_eq!(span.bytes, (32, 32 + 12 + 100 + 12 + 5 + 12 + 6));
        // A decoder holding frame 1 needs only frame 2; one holding a frame of another group
        // starts over at the keyframe.
        assert_eq!(cam.span_to(2, Some(1)).first, 2);
        assert_eq!(cam.span_to(4, Some(2)).first, 3);
    }

    #[test]
    fn every_bad_index_field_is_named() {
        let good = index().encode();
        let expect = |bytes: &[u8], cameras: usize, steps: u32, field: &str| {
            let err = FrameIndex::parse(bytes, cameras, steps, "frames.idx").unwrap_err().to_string();
            assert!(err.contains(field), "expected {field} in {err}");
        };
        expect(&good[..10], 2, 5, "(header)");
        expect(&good, 3, 5, "camera_count");
        expect(&good, 2, 6, "step_count");
        expect(&good[..good.len() - 1], 2, 5, "(file)");
        let mut flipped = good.clone();
        flipped[40] ^= 1;
        assert!(matches!(FrameIndex::parse(&flipped, 2, 5, "frames.idx"), Err(SceneError::Checksum { .. })));
        // Re-encoded (valid checksum) but inconsistent: absurd counts, no first keyframe,
        // lengths that do not add up to the file.
        let mut idx = index();
        idx.cameras[0].frames[0].key = false;
        expect(&idx.encode(), 2, 5, "cameras[0].frames[0]");
        let mut idx = index();
        idx.cameras[1].ivf_byte_length += 1;
        expect(&idx.encode(), 2, 5, "cameras[1].ivf_byte_length");
        let mut idx = index();
        idx.cameras[1].frames[3].length = 0;
        expect(&idx.encode(), 2, 5, "cameras[1].frames[3]");
        let mut absurd = good.clone();
        absurd[16..20].copy_from_slice(&u32::MAX.to_le_bytes());
        expect(&absurd, 2, u32::MAX, "step_count");
        // Frames each within the limit, but a group a reader could not fetch in one range.
        let big = FrameIndex { cameras: vec![frames(&[true, false, true], &[200 << 20, 100 << 20, 1])] };
        expect(&big.encode(), 1, 3, "cameras[0].frames[1]");
    }

    #[test]
    fn groups_longer_than_the_limit_are_refused() {
        let steps = MAX_KEYFRAME_INTERVAL + 1;
        let mut keys = vec![false; steps as usize];
        keys[0] = true;
        let idx = FrameIndex { cameras: vec![frames(&keys, &vec![1; steps as usize])] };
        let err = FrameIndex::parse(&idx.encode(), 1, steps, "frames.idx").unwrap_err().to_string();
        assert!(err.contains(&format!("frames[{MAX_KEYFRAME_INTERVAL}]")), "{err}");
    }

    #[test]
    fn vp9_frame_kinds_are_read_from_the_first_byte() {
        assert_eq!(Vp9FrameKind::parse(&[0b1000_0010]), Some(Vp9FrameKind { key: true, shown: true }));
        assert_eq!(Vp9FrameKind::parse(&[0b1000_0110]), Some(Vp9FrameKind { key: false, shown: true }));
        assert_eq!(Vp9FrameKind::parse(&[0b1000_0100]), Some(Vp9FrameKind { key: false, shown: false }));
        assert_eq!(Vp9FrameKind::parse(&[0b1000_1000]), Some(Vp9FrameKind { key: false, shown: false }));
        assert_eq!(Vp9FrameKind::parse(&[0b0100_0010]), None);
        assert_eq!(Vp9FrameKind::parse(&[]), None);
    }

    #[test]
    fn an_ivf_file_is_scanned_into_its_frames_and_payloads_are_checked() {
        let mut ivf = IvfHeader::vp9(4, 2, 3).to_vec();
        for payload in [&[0b1000_0010u8, 1, 2][..], &[0b1000_0110, 9], &[0b1000_0110, 7, 7, 7]] {
            ivf.extend_from_slice(&(payload.len() as u32).to_le_bytes());
            ivf.extend_from_slice(&[0; 8]);
            ivf.extend_from_slice(payload);
        }
        let cam = scan_ivf(&ivf, 4, 2, "cam.ivf").unwrap();
        assert_eq!(cam.frames.iter().map(|f| (f.key, f.length)).collect::<Vec<_>>(), [(true, 3), (false, 2), (false, 4)]);
        let span = cam.span_to(2, None);
        let bytes = &ivf[span.bytes.0 as usize..span.bytes.1 as usize];
        let payloads = cam.payloads(&span, bytes, "cam.ivf").unwrap();
        assert_eq!(payloads[2], &[0b1000_0110, 7, 7, 7]);
        // An index that disagrees with the file, or a short read, is named.
        let mut lying = cam.clone();
        lying.frames[1].key = true;
        assert!(lying.payloads(&span, bytes, "cam.ivf").unwrap_err().to_string().contains("frame 1"));
        assert!(cam.payloads(&span, &bytes[1..], "cam.ivf").is_err());
        assert!(scan_ivf(&ivf, 5, 2, "cam.ivf").unwrap_err().to_string().contains("(frame size)"));
        assert!(scan_ivf(&ivf[..ivf.len() - 1], 4, 2, "cam.ivf").unwrap_err().to_string().contains("frame 2"));
    }
}
