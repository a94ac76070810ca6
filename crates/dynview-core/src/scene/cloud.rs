//! `clouds.bin`: the per-timestep sparse clouds in one file with an offset table.
//!
//! Layout (all little-endian; see `docs/FORMAT.md`):
//!
//! | offset | size | field |
//! | --- | --- | --- |
//! | 0 | 8 | magic `DVCLOUDS` |
//! | 8 | 4 | `version` (u32, 1) |
//! | 12 | 4 | `step_count` (u32) |
//! | 16 | 12 | `bounds_min` (3 x f32) |
//! | 28 | 12 | `bounds_max` (3 x f32) |
//! | 40 | 4 | `reserved` (u32, 0) |
//! | 44 | 4 | `header_crc32`: CRC-32 of bytes 0..44 followed by the offset table |
//! | 48 | 16 x step_count | offset table: per step `offset` (u64), `point_count` (u32), `crc32` (u32) of its block |
//! | ... | 9 x point_count | per step, contiguous and in order: per point `x, y, z` (u16, quantised in the bounds) then `r, g, b` (u8) |
//!
//! A reader fetches the header and table once, then any step's block alone.

use super::error::{SceneError, SceneResult};
use super::limits::{MAX_POINTS_PER_STEP, MAX_TIME_STEPS};

/// The magic bytes opening a clouds file.
pub const CLOUDS_MAGIC: &[u8; 8] = b"DVCLOUDS";
/// The clouds file version.
pub const CLOUDS_VERSION: u32 = 1;
/// Size of the fixed header in bytes.
pub const HEADER_BYTES: usize = 48;
/// Size of one offset-table entry in bytes.
pub const TABLE_ENTRY_BYTES: usize = 16;
/// Size of one stored point in bytes.
pub const POINT_BYTES: usize = 9;
const QUANT_MAX: f32 = 65535.0;

/// A colored point cloud of one time step.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointCloud {
    /// World positions.
    pub positions_world: Vec<[f32; 3]>,
    /// 8-bit colors, one per position.
    pub colors: Vec<[u8; 3]>,
}

impl PointCloud {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.positions_world.len()
    }

    /// True without points.
    pub fn is_empty(&self) -> bool {
        self.positions_world.is_empty()
    }
}

/// One entry of the offset table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepEntry {
    /// Byte offset of the step's block from the start of the file.
    pub offset: u64,
    /// Points in the block.
    pub point_count: u32,
    /// CRC-32 of the block.
    pub crc32: u32,
}

impl StepEntry {
    /// Length of the block in bytes.
    pub fn byte_length(&self) -> u64 {
        u64::from(self.point_count) * POINT_BYTES as u64
    }
}

/// The parsed header and offset table: everything needed to fetch and decode one step.
#[derive(Clone, Debug, PartialEq)]
pub struct CloudIndex {
    /// Quantisation box, smallest corner.
    pub bounds_min: [f32; 3],
    /// Quantisation box, largest corner.
    pub bounds_max: [f32; 3],
    /// One entry per time step.
    pub steps: Vec<StepEntry>,
}

/// Bytes needed from the start of the file to parse the index of `step_count` steps.
pub fn index_byte_length(step_count: u32) -> u64 {
    HEADER_BYTES as u64 + u64::from(step_count) * TABLE_ENTRY_BYTES as u64
}

fn read_u32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn read_f32(b: &[u8], at: usize) -> f32 {
    f32::from_bits(read_u32(b, at))
}

fn read_u64(b: &[u8], at: usize) -> u64 {
    u64::from(read_u32(b, at)) | (u64::from(read_u32(b, at + 4)) << 32)
}

impl CloudIndex {
    /// Reads the step count from the first bytes of a file (at least `HEADER_BYTES`), so a
    /// reader knows how many bytes the whole index takes.
    pub fn peek_step_count(header: &[u8], file: &str) -> SceneResult<u32> {
        if header.len() < HEADER_BYTES {
            return Err(SceneError::invalid(file, "(header)", format!("file shorter than the {HEADER_BYTES}-byte header")));
        }
        if &header[..8] != CLOUDS_MAGIC {
            return Err(SceneError::invalid(file, "magic", "not a dynview clouds file"));
        }
        let version = read_u32(header, 8);
        if version != CLOUDS_VERSION {
            return Err(SceneError::invalid(
                file,
                "version",
                format!("unsupported version {version} (this reader knows {CLOUDS_VERSION})"),
            ));
        }
        let step_count = read_u32(header, 12);
        if step_count == 0 || step_count > MAX_TIME_STEPS {
            return Err(SceneError::invalid(file, "step_count", format!("must be in 1..={MAX_TIME_STEPS}, found {step_count}")));
        }
        Ok(step_count)
    }

    /// Parses and checks the header and offset table. `bytes` holds at least the index (more
    /// is ignored); `file_length` is the size of the whole file, which every block must fit.
    pub fn parse(bytes: &[u8], file_length: u64, file: &str) -> SceneResult<Self> {
        let step_count = Self::peek_step_count(bytes, file)?;
        let index_len = index_byte_length(step_count);
        if (bytes.len() as u64) < index_len || file_length < index_len {
            return Err(SceneError::invalid(file, "steps", format!("file too short for the offset table of {step_count} steps")));
        }
        let index_len = index_len as usize;
        let stored = read_u32(bytes, 44);
        let mut hasher = crc32fast::Hasher::new();
        hasher.update(&bytes[..44]);
        hasher.update(&bytes[HEADER_BYTES..index_len]);
        let computed = hasher.finalize();
        if stored != computed {
            return Err(SceneError::Checksum { file: file.to_owned(), field: "header_crc32".into(), stored, computed });
        }
        let bounds_min = [read_f32(bytes, 16), read_f32(bytes, 20), read_f32(bytes, 24)];
        let bounds_max = [read_f32(bytes, 28), read_f32(bytes, 32), read_f32(bytes, 36)];
        for axis in 0..3 {
            let (lo, hi) = (bounds_min[axis], bounds_max[axis]);
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(SceneError::invalid(
                    file,
                    format!("bounds[axis {axis}]"),
                    format!("min {lo} and max {hi} must be finite with min <= max"),
                ));
            }
        }
        if read_u32(bytes, 40) != 0 {
            return Err(SceneError::invalid(file, "reserved", "must be 0"));
        }
        let mut steps = Vec::with_capacity(step_count as usize);
        let mut expected_offset = index_len as u64;
        for t in 0..step_count as usize {
            let at = HEADER_BYTES + t * TABLE_ENTRY_BYTES;
            let entry = StepEntry { offset: read_u64(bytes, at), point_count: read_u32(bytes, at + 8), crc32: read_u32(bytes, at + 12) };
            if entry.point_count > MAX_POINTS_PER_STEP {
                return Err(SceneError::invalid(
                    file,
                    format!("steps[{t}].point_count"),
                    format!("{} exceeds the limit of {MAX_POINTS_PER_STEP}", entry.point_count),
                ));
            }
            if entry.offset != expected_offset {
                return Err(SceneError::invalid(
                    file,
                    format!("steps[{t}].offset"),
                    format!("is {}, blocks must be contiguous so it must be {expected_offset}", entry.offset),
                ));
            }
            expected_offset += entry.byte_length();
            if expected_offset > file_length {
                return Err(SceneError::invalid(
                    file,
                    format!("steps[{t}].point_count"),
                    format!("block ends at byte {expected_offset}, past the end of the file ({file_length} bytes)"),
                ));
            }
            steps.push(entry);
        }
        if expected_offset != file_length {
            return Err(SceneError::invalid(
                file,
                "(file length)",
                format!("blocks end at byte {expected_offset} but the file has {file_length} bytes"),
            ));
        }
        Ok(Self { bounds_min, bounds_max, steps })
    }

    /// Total points over all steps.
    pub fn total_points(&self) -> u64 {
        self.steps.iter().map(|s| u64::from(s.point_count)).sum()
    }

    /// Decodes the block of step `t` (exactly its bytes), checking length and checksum.
    pub fn decode_step(&self, t: usize, block: &[u8], file: &str) -> SceneResult<PointCloud> {
        let Some(entry) = self.steps.get(t) else {
            return Err(SceneError::invalid(file, "steps", format!("time step {t} out of range (0..{})", self.steps.len())));
        };
        if block.len() as u64 != entry.byte_length() {
            return Err(SceneError::invalid(
                file,
                format!("steps[{t}]"),
                format!("block has {} bytes, expected {}", block.len(), entry.byte_length()),
            ));
        }
        let computed = crc32fast::hash(block);
        if computed != entry.crc32 {
            return Err(SceneError::Checksum { file: file.to_owned(), field: format!("steps[{t}].crc32"), stored: entry.crc32, computed });
        }
        let scale: [f32; 3] = std::array::from_fn(|i| (self.bounds_max[i] - self.bounds_min[i]) / QUANT_MAX);
        let n = entry.point_count as usize;
        let mut cloud = PointCloud { positions_world: Vec::with_capacity(n), colors: Vec::with_capacity(n) };
        for p in block.chunks_exact(POINT_BYTES) {
            let q = [u16::from_le_bytes([p[0], p[1]]), u16::from_le_bytes([p[2], p[3]]), u16::from_le_bytes([p[4], p[5]])];
            cloud.positions_world.push(std::array::from_fn(|i| self.bounds_min[i] + f32::from(q[i]) * scale[i]));
            cloud.colors.push([p[6], p[7], p[8]]);
        }
        Ok(cloud)
    }
}

/// Encodes one step's points into a block, quantising positions into the bounds (points
/// outside are clamped onto the box). Fails on non-finite positions or too many points.
pub fn encode_step(cloud: &PointCloud, bounds_min: [f32; 3], bounds_max: [f32; 3], t: usize) -> SceneResult<Vec<u8>> {
    const FILE: &str = "clouds.bin";
    if cloud.positions_world.len() != cloud.colors.len() {
        return Err(SceneError::invalid(FILE, format!("steps[{t}]"), "positions and colors differ in length"));
    }
    if cloud.len() > MAX_POINTS_PER_STEP as usize {
        return Err(SceneError::invalid(FILE, format!("steps[{t}].point_count"), format!("{} exceeds {MAX_POINTS_PER_STEP}", cloud.len())));
    }
    let inv: [f32; 3] = std::array::from_fn(|i| {
        let extent = bounds_max[i] - bounds_min[i];
        if extent > 0.0 { QUANT_MAX / extent } else { 0.0 }
    });
    let mut out = Vec::with_capacity(cloud.len() * POINT_BYTES);
    for (k, (p, c)) in cloud.positions_world.iter().zip(&cloud.colors).enumerate() {
        if p.iter().any(|v| !v.is_finite()) {
            return Err(SceneError::invalid(FILE, format!("steps[{t}].points[{k}]"), "non-finite position"));
        }
        for i in 0..3 {
            let q = ((p[i] - bounds_min[i]) * inv[i]).round().clamp(0.0, QUANT_MAX) as u16;
            out.extend_from_slice(&q.to_le_bytes());
        }
        out.extend_from_slice(c);
    }
    Ok(out)
}

/// Builds the header and offset table for blocks of the given lengths (in points) and CRCs.
pub fn encode_index(bounds_min: [f32; 3], bounds_max: [f32; 3], steps: &[(u32, u32)]) -> Vec<u8> {
    let index_len = index_byte_length(steps.len() as u32) as usize;
    let mut out = Vec::with_capacity(index_len);
    out.extend_from_slice(CLOUDS_MAGIC);
    out.extend_from_slice(&CLOUDS_VERSION.to_le_bytes());
    out.extend_from_slice(&(steps.len() as u32).to_le_bytes());
    for v in bounds_min.iter().chain(&bounds_max) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes()); // header_crc32, filled below
    let mut offset = index_len as u64;
    for &(point_count, crc32) in steps {
        out.extend_from_slice(&offset.to_le_bytes());
        out.extend_from_slice(&point_count.to_le_bytes());
        out.extend_from_slice(&crc32.to_le_bytes());
        offset += u64::from(point_count) * POINT_BYTES as u64;
    }
    let mut hasher = crc32fast::Hasher::new();
    hasher.update(&out[..44]);
    hasher.update(&out[HEADER_BYTES..]);
    let crc = hasher.finalize();
    out[44..48].copy_from_slice(&crc.to_le_bytes());
    out
}

/// Encodes a whole clouds file in memory (used for small packages and tests; the package
/// writer streams blocks to disk instead).
pub fn encode_clouds(bounds_min: [f32; 3], bounds_max: [f32; 3], clouds: &[PointCloud]) -> SceneResult<Vec<u8>> {
    let mut blocks = Vec::with_capacity(clouds.len());
    for (t, cloud) in clouds.iter().enumerate() {
        blocks.push(encode_step(cloud, bounds_min, bounds_max, t)?);
    }
    let entries: Vec<(u32, u32)> = blocks.iter().map(|b| ((b.len() / POINT_BYTES) as u32, crc32fast::hash(b))).collect();
    let mut out = encode_index(bounds_min, bounds_max, &entries);
    for b in blocks {
        out.extend_from_slice(&b);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_clouds() -> Vec<PointCloud> {
        vec![
            PointCloud {
                positions_world: vec![[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [-1.0, 0.5, 2.5]],
                colors: vec![[255, 0, 0], [0, 255, 0], [1, 2, 3]],
            },
            PointCloud::default(),
            PointCloud { positions_world: vec![[0.25, 1.0, -0.5]], colors: vec![[9, 9, 9]] },
        ]
    }

    const MIN: [f32; 3] = [-1.0, 0.0, -1.0];
    const MAX: [f32; 3] = [1.0, 2.0, 3.0];

    #[test]
    fn round_trip_within_quantisation() {
        let clouds = sample_clouds();
        let bytes = encode_clouds(MIN, MAX, &clouds).unwrap();
        let index = CloudIndex::parse(&bytes, bytes.len() as u64, "clouds.bin").unwrap();
        assert_eq!(index.steps.len(), 3);
        assert_eq!(index.total_points(), 4);
        for (t, cloud) in clouds.iter().enumerate() {
            let e = index.steps[t];
            let block = &bytes[e.offset as usize..(e.offset + e.byte_length()) as usize];
            let back = index.decode_step(t, block, "clouds.bin").unwrap();
            assert_eq!(back.colors, cloud.colors);
            for (a, b) in back.positions_world.iter().zip(&cloud.positions_world) {
                for i in 0..3 {
                    let step = (MAX[i] - MIN[i]) / 65535.0;
                    assert!((a[i] - b[i]).abs() <= 0.5 * step + 1e-6, "{a:?} vs {b:?}");
                }
            }
        }
    }

    #[test]
    fn every_truncation_is_an_error() {
        let bytes = encode_clouds(MIN, MAX, &sample_clouds()).unwrap();
        for len in 0..bytes.len() {
            assert!(CloudIndex::parse(&bytes[..len], len as u64, "clouds.bin").is_err(), "length {len}");
        }
    }

    #[test]
    fn every_bit_flip_is_detected() {
        let bytes = encode_clouds(MIN, MAX, &sample_clouds()).unwrap();
        for i in 0..bytes.len() {
            for bit in 0..8 {
                let mut bad = bytes.clone();
                bad[i] ^= 1 << bit;
                let detected = match CloudIndex::parse(&bad, bad.len() as u64, "clouds.bin") {
                    Err(_) => true,
                    Ok(index) => (0..index.steps.len()).any(|t| {
                        let e = index.steps[t];
                        let block = &bad[e.offset as usize..(e.offset + e.byte_length()) as usize];
                        index.decode_step(t, block, "clouds.bin").is_err()
                    }),
                };
                assert!(detected, "flip of bit {bit} in byte {i} went unnoticed");
            }
        }
    }

    #[test]
    fn errors_name_fields() {
        let bytes = encode_clouds(MIN, MAX, &sample_clouds()).unwrap();
        let mut bad = bytes.clone();
        bad[8] = 2;
        let err = CloudIndex::parse(&bad, bad.len() as u64, "clouds.bin").unwrap_err().to_string();
        assert!(err.contains("`version`"), "{err}");
        let err = CloudIndex::parse(&bytes, bytes.len() as u64 + 9, "clouds.bin").unwrap_err().to_string();
        assert!(err.contains("file length"), "{err}");
        let index = CloudIndex::parse(&bytes, bytes.len() as u64, "clouds.bin").unwrap();
        let err = index.decode_step(7, &[], "clouds.bin").unwrap_err().to_string();
        assert!(err.contains("out of range"), "{err}");
    }

    #[test]
    fn encode_rejects_nan_and_clamps_outside() {
        let nan = PointCloud { positions_world: vec![[f32::NAN, 0.0, 0.0]], colors: vec![[0; 3]] };
        assert!(encode_step(&nan, MIN, MAX, 0).is_err());
        let outside = PointCloud { positions_world: vec![[50.0, -50.0, 1.0]], colors: vec![[0; 3]] };
        let block = encode_step(&outside, MIN, MAX, 0).unwrap();
        assert_eq!(&block[0..4], &[0xff, 0xff, 0, 0]);
    }
}
