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
//! | 40 | 4 | `reserved` (u32, 0; version 2: `position_bits` (u16, 1 to 16), then `color_bits` (u16, 4 to 8)) |
//! | 44 | 4 | `header_crc32`: CRC-32 of bytes 0..44 followed by the offset table |
//! | 48 | 16 x step_count | offset table: per step `offset` (u64), `point_count` (u32), `crc32` (u32) of its block |
//! | ... | 9 x point_count | per step, contiguous and in order: per point `x, y, z` (u16, quantised in the bounds) then `r, g, b` (u8) |
//!
//! A reader fetches the header and table once, then any step's block alone. Positions are cells
//! of the file's quantisation grid ([`super::cloud_grid`]); [`super::cloud_encode`] writes
//! the file.
//!
//! Version 2 (format v2 packages) stores the event's static cloud once, as the first block, and
//! per step a coded block of the step's own points and the indices of the static points it
//! borrows ([`super::cloud_coding`]); its table entries are 24 bytes: `offset` (u64),
//! `byte_length`, `point_count` (own + borrowed), `borrowed_count`, `crc32` (u32 each), the
//! static block's first.

use super::cloud_coding::decode_block;
use super::cloud_grid::Grid;
use super::error::{SceneError, SceneResult};
use super::limits::{MAX_POINTS_PER_STEP, MAX_TIME_STEPS};
use crate::points::PointCloud;

/// The magic bytes opening a clouds file.
pub const CLOUDS_MAGIC: &[u8; 8] = b"DVCLOUDS";
/// The clouds file version of plain blocks (format v1 packages).
pub const CLOUDS_VERSION: u32 = 1;
/// The clouds file version of coded blocks and a static cloud (format v2 packages).
pub const CLOUDS_VERSION_CODED: u32 = 2;
/// Size of the fixed header in bytes.
pub const HEADER_BYTES: usize = 48;
/// Size of one offset-table entry in bytes (version 1).
pub const TABLE_ENTRY_BYTES: usize = 16;
/// Size of one offset-table entry in bytes (version 2).
pub const CODED_TABLE_ENTRY_BYTES: usize = 24;
/// Largest coded block accepted (version 2).
pub const MAX_CODED_BLOCK_BYTES: u64 = 64 << 20;
/// Size of one stored point in bytes.
pub const POINT_BYTES: usize = 9;

/// One entry of the offset table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepEntry {
    /// Byte offset of the step's block from the start of the file.
    pub offset: u64,
    /// Length of the block in bytes.
    pub length_bytes: u64,
    /// Points the block decodes to (its own and, version 2, the borrowed static points).
    pub point_count: u32,
    /// Static points borrowed (version 2; 0 otherwise).
    pub borrowed_count: u32,
    /// CRC-32 of the block.
    pub crc32: u32,
}

impl StepEntry {
    /// Length of the block in bytes.
    pub fn byte_length(&self) -> u64 {
        self.length_bytes
    }

    /// A version 1 entry: `point_count` plain points.
    pub fn plain(offset: u64, point_count: u32, crc32: u32) -> Self {
        Self { offset, length_bytes: u64::from(point_count) * POINT_BYTES as u64, point_count, borrowed_count: 0, crc32 }
    }
}

/// The parsed header and offset table: everything needed to fetch and decode one step.
#[derive(Clone, Debug, PartialEq)]
pub struct CloudIndex {
    /// The clouds file version (1 or 2).
    pub version: u32,
    /// The static cloud's block (version 2).
    pub static_block: Option<StepEntry>,
    /// Quantisation box, smallest corner.
    pub bounds_min: [f32; 3],
    /// Quantisation box, largest corner.
    pub bounds_max: [f32; 3],
    /// Bits per coordinate of the quantisation grid (16 in version 1).
    pub position_bits: u32,
    /// Bits per color channel (8 in version 1).
    pub color_bits: u32,
    /// One entry per time step.
    pub steps: Vec<StepEntry>,
}

/// Bytes needed from the start of a clouds file of `version` to parse the index of
/// `step_count` steps.
pub fn index_byte_length(version: u32, step_count: u32) -> u64 {
    if version == CLOUDS_VERSION_CODED {
        HEADER_BYTES as u64 + (u64::from(step_count) + 1) * CODED_TABLE_ENTRY_BYTES as u64
    } else {
        HEADER_BYTES as u64 + u64::from(step_count) * TABLE_ENTRY_BYTES as u64
    }
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
    /// Reads the version and step count from the first bytes of a file (at least
    /// `HEADER_BYTES`), so a reader knows how many bytes the whole index takes
    /// ([`index_byte_length`]).
    pub fn peek(header: &[u8], file: &str) -> SceneResult<(u32, u32)> {
        if header.len() < HEADER_BYTES {
            return Err(SceneError::invalid(file, "(header)", format!("file shorter than the {HEADER_BYTES}-byte header")));
        }
        if &header[..8] != CLOUDS_MAGIC {
            return Err(SceneError::invalid(file, "magic", "not a dynview clouds file"));
        }
        let version = read_u32(header, 8);
        if version != CLOUDS_VERSION && version != CLOUDS_VERSION_CODED {
            return Err(SceneError::invalid(
                file,
                "version",
                format!("unsupported version {version} (this reader knows {CLOUDS_VERSION} and {CLOUDS_VERSION_CODED})"),
            ));
        }
        let step_count = read_u32(header, 12);
        if step_count == 0 || step_count > MAX_TIME_STEPS {
            return Err(SceneError::invalid(file, "step_count", format!("must be in 1..={MAX_TIME_STEPS}, found {step_count}")));
        }
        Ok((version, step_count))
    }

    /// Parses and checks the header and offset table. `bytes` holds at least the index (more
    /// is ignored); `file_length` is the size of the whole file, which every block must fit.
    pub fn parse(bytes: &[u8], file_length: u64, file: &str) -> SceneResult<Self> {
        let (version, step_count) = Self::peek(bytes, file)?;
        let index_len = index_byte_length(version, step_count);
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
        if version == CLOUDS_VERSION && read_u32(bytes, 40) != 0 {
            return Err(SceneError::invalid(file, "reserved", "must be 0"));
        }
        let (position_bits, color_bits) = if version == CLOUDS_VERSION {
            (16, 8)
        } else {
            (u32::from(u16::from_le_bytes([bytes[40], bytes[41]])), u32::from(u16::from_le_bytes([bytes[42], bytes[43]])))
        };
        if !(1..=16).contains(&position_bits) {
            return Err(SceneError::invalid(file, "position_bits", format!("must be in 1..=16, found {position_bits}")));
        }
        if !(4..=8).contains(&color_bits) {
            return Err(SceneError::invalid(file, "color_bits", format!("must be in 4..=8, found {color_bits}")));
        }
        let coded = version == CLOUDS_VERSION_CODED;
        let entry_bytes = if coded { CODED_TABLE_ENTRY_BYTES } else { TABLE_ENTRY_BYTES };
        let blocks = step_count as usize + usize::from(coded);
        let mut entries = Vec::with_capacity(blocks);
        let mut expected_offset = index_len as u64;
        for k in 0..blocks {
            let at = HEADER_BYTES + k * entry_bytes;
            let name = if coded && k == 0 { "static".to_string() } else { format!("steps[{}]", k - usize::from(coded)) };
            let entry = if coded {
                StepEntry {
                    offset: read_u64(bytes, at),
                    length_bytes: u64::from(read_u32(bytes, at + 8)),
                    point_count: read_u32(bytes, at + 12),
                    borrowed_count: read_u32(bytes, at + 16),
                    crc32: read_u32(bytes, at + 20),
                }
            } else {
                StepEntry::plain(read_u64(bytes, at), read_u32(bytes, at + 8), read_u32(bytes, at + 12))
            };
            if entry.point_count > MAX_POINTS_PER_STEP
                || entry.borrowed_count > entry.point_count
                || (k == 0 && coded && entry.borrowed_count != 0)
            {
                return Err(SceneError::invalid(
                    file,
                    format!("{name}.point_count"),
                    format!(
                        "{} points ({} borrowed): the limit is {MAX_POINTS_PER_STEP}, borrowed at most all of them, none in the static block",
                        entry.point_count, entry.borrowed_count
                    ),
                ));
            }
            if coded && entry.length_bytes > MAX_CODED_BLOCK_BYTES {
                return Err(SceneError::invalid(
                    file,
                    format!("{name}.byte_length"),
                    format!("{} exceeds {MAX_CODED_BLOCK_BYTES}", entry.length_bytes),
                ));
            }
            if entry.offset != expected_offset {
                return Err(SceneError::invalid(
                    file,
                    format!("{name}.offset"),
                    format!("is {}, blocks must be contiguous so it must be {expected_offset}", entry.offset),
                ));
            }
            expected_offset += entry.byte_length();
            if expected_offset > file_length {
                return Err(SceneError::invalid(
                    file,
                    format!("{name}.point_count"),
                    format!("block ends at byte {expected_offset}, past the end of the file ({file_length} bytes)"),
                ));
            }
            entries.push(entry);
        }
        if expected_offset != file_length {
            return Err(SceneError::invalid(
                file,
                "(file length)",
                format!("blocks end at byte {expected_offset} but the file has {file_length} bytes"),
            ));
        }
        let static_block = if coded { Some(entries.remove(0)) } else { None };
        let steps = entries;
        if let Some(statics) = static_block
            && let Some(t) = steps.iter().position(|s| s.borrowed_count > statics.point_count)
        {
            return Err(SceneError::invalid(
                file,
                format!("steps[{t}].borrowed_count"),
                format!("more than the {} static points", statics.point_count),
            ));
        }
        Ok(Self { version, static_block, bounds_min, bounds_max, position_bits, color_bits, steps })
    }

    /// The quantisation grid.
    pub fn grid(&self) -> Grid {
        Grid { bounds_min: self.bounds_min, bounds_max: self.bounds_max, position_bits: self.position_bits, color_bits: self.color_bits }
    }

    /// Total points over all steps.
    pub fn total_points(&self) -> u64 {
        self.steps.iter().map(|s| u64::from(s.point_count)).sum()
    }

    /// Checks a block's length and checksum against its entry.
    fn check_block(entry: &StepEntry, block: &[u8], file: &str, name: &str) -> SceneResult<()> {
        if block.len() as u64 != entry.byte_length() {
            return Err(SceneError::invalid(file, name, format!("block has {} bytes, expected {}", block.len(), entry.byte_length())));
        }
        let computed = crc32fast::hash(block);
        if computed != entry.crc32 {
            return Err(SceneError::Checksum { file: file.to_owned(), field: format!("{name}.crc32"), stored: entry.crc32, computed });
        }
        Ok(())
    }

    /// Decodes the static cloud's block (version 2; exactly its bytes).
    pub fn decode_static(&self, block: &[u8], file: &str) -> SceneResult<PointCloud> {
        let Some(entry) = self.static_block else {
            return Err(SceneError::invalid(file, "static", "a version 1 clouds file has no static cloud"));
        };
        Self::check_block(&entry, block, file, "static")?;
        let (cloud, _) = decode_block(block, entry.point_count, 0, 0, &self.grid(), file, "static")?;
        Ok(cloud)
    }

    /// Decodes the block of step `t` (exactly its bytes), checking length and checksum. A
    /// version 2 step needs the static cloud ([`CloudIndex::decode_static`]) it borrows from;
    /// its points are its own, then the borrowed ones.
    pub fn decode_step(&self, t: usize, block: &[u8], statics: Option<&PointCloud>, file: &str) -> SceneResult<PointCloud> {
        let static_count = statics.map_or(0, |s| s.len() as u32);
        let (mut cloud, borrowed) = self.decode_step_parts(t, block, static_count, file)?;
        if !borrowed.is_empty() {
            let Some(statics) = statics else {
                return Err(SceneError::invalid(file, "static", "the static cloud is needed to decode a step"));
            };
            cloud.extend_indexed(statics, borrowed.iter().map(|&i| i as usize));
        }
        Ok(cloud)
    }

    /// Decodes the block of step `t` into its own points and the indices of the static points
    /// it borrows (each below `static_count`; none in a version 1 file).
    pub fn decode_step_parts(&self, t: usize, block: &[u8], static_count: u32, file: &str) -> SceneResult<(PointCloud, Vec<u32>)> {
        let Some(entry) = self.steps.get(t) else {
            return Err(SceneError::invalid(file, "steps", format!("time step {t} out of range (0..{})", self.steps.len())));
        };
        let name = format!("steps[{t}]");
        Self::check_block(entry, block, file, &name)?;
        if self.version == CLOUDS_VERSION_CODED {
            let own = entry.point_count - entry.borrowed_count;
            return decode_block(block, own, entry.borrowed_count, static_count, &self.grid(), file, &name);
        }
        let n = entry.point_count as usize;
        let mut cloud = PointCloud { positions_world: Vec::with_capacity(n), colors: Vec::with_capacity(n) };
        for p in block.chunks_exact(POINT_BYTES) {
            let q = [u16::from_le_bytes([p[0], p[1]]), u16::from_le_bytes([p[2], p[3]]), u16::from_le_bytes([p[4], p[5]])];
            cloud.positions_world.push(Grid::full(self.bounds_min, self.bounds_max).dequantise(q));
            cloud.colors.push([p[6], p[7], p[8]]);
        }
        Ok((cloud, Vec::new()))
    }
}
