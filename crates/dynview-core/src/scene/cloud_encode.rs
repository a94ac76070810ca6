//! Writing `clouds.bin` ([`super::cloud`] describes the layout): version 1 blocks of plain
//! points, the header and offset table of either version, and whole files in memory (small
//! packages and tests; the package writer streams its blocks to disk instead).

use super::cloud::{CLOUDS_MAGIC, CLOUDS_VERSION, CLOUDS_VERSION_CODED, HEADER_BYTES, POINT_BYTES, StepEntry, index_byte_length};
use super::cloud_coding::encode_block;
use super::cloud_grid::Grid;
use super::error::{SceneError, SceneResult};
use super::limits::MAX_POINTS_PER_STEP;
use crate::points::PointCloud;

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
    let mut out = Vec::with_capacity(cloud.len() * POINT_BYTES);
    for (k, (p, c)) in cloud.positions_world.iter().zip(&cloud.colors).enumerate() {
        let q = Grid::full(bounds_min, bounds_max)
            .quantise(*p)
            .ok_or_else(|| SceneError::invalid(FILE, format!("steps[{t}].points[{k}]"), "non-finite position"))?;
        for v in q {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(c);
    }
    Ok(out)
}

/// Builds the header and offset table of a version 1 file for blocks of the given lengths (in
/// points) and CRCs.
pub fn encode_index(bounds_min: [f32; 3], bounds_max: [f32; 3], steps: &[(u32, u32)]) -> Vec<u8> {
    let index_len = index_byte_length(CLOUDS_VERSION, steps.len() as u32);
    let mut offset = index_len;
    let entries: Vec<StepEntry> = steps
        .iter()
        .map(|&(point_count, crc32)| {
            let e = StepEntry::plain(offset, point_count, crc32);
            offset += e.byte_length();
            e
        })
        .collect();
    encode_table(CLOUDS_VERSION, &Grid::full(bounds_min, bounds_max), None, &entries)
}

/// Builds the header and offset table of a version 2 file on `grid`: the static block, then
/// one block per step, as `(byte_length, point_count, borrowed_count, crc32)`.
pub fn encode_coded_index(grid: &Grid, statics: (u32, u32, u32), steps: &[(u32, u32, u32, u32)]) -> Vec<u8> {
    let mut offset = index_byte_length(CLOUDS_VERSION_CODED, steps.len() as u32);
    let mut entry = |(length, point_count, borrowed_count, crc32): (u32, u32, u32, u32)| {
        let e = StepEntry { offset, length_bytes: u64::from(length), point_count, borrowed_count, crc32 };
        offset += e.byte_length();
        e
    };
    let static_entry = entry((statics.0, statics.1, 0, statics.2));
    let entries: Vec<StepEntry> = steps.iter().map(|&s| entry(s)).collect();
    encode_table(CLOUDS_VERSION_CODED, grid, Some(static_entry), &entries)
}

fn encode_table(version: u32, grid: &Grid, static_entry: Option<StepEntry>, steps: &[StepEntry]) -> Vec<u8> {
    let mut out = Vec::with_capacity(index_byte_length(version, steps.len() as u32) as usize);
    out.extend_from_slice(CLOUDS_MAGIC);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(steps.len() as u32).to_le_bytes());
    for v in grid.bounds_min.iter().chain(&grid.bounds_max) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    let (position_bits, color_bits) = if version == CLOUDS_VERSION_CODED { (grid.position_bits, grid.color_bits) } else { (0, 0) };
    out.extend_from_slice(&(position_bits as u16).to_le_bytes());
    out.extend_from_slice(&(color_bits as u16).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes()); // header_crc32, filled below
    for e in static_entry.iter().chain(steps) {
        out.extend_from_slice(&e.offset.to_le_bytes());
        if version == CLOUDS_VERSION_CODED {
            out.extend_from_slice(&(e.length_bytes as u32).to_le_bytes());
            out.extend_from_slice(&e.point_count.to_le_bytes());
            out.extend_from_slice(&e.borrowed_count.to_le_bytes());
        } else {
            out.extend_from_slice(&e.point_count.to_le_bytes());
        }
        out.extend_from_slice(&e.crc32.to_le_bytes());
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

/// Encodes a whole version 2 clouds file in memory on `grid`: the static cloud, then per step
/// its own points and the static indices it borrows (for tests and small packages).
pub fn encode_coded_clouds(grid: &Grid, statics: &PointCloud, steps: &[(PointCloud, Vec<u32>)]) -> SceneResult<Vec<u8>> {
    let static_block = encode_block(statics, &[], grid, "static")?;
    let mut blocks = Vec::with_capacity(steps.len());
    for (t, (own, borrowed)) in steps.iter().enumerate() {
        blocks.push((encode_block(own, borrowed, grid, &format!("steps[{t}]"))?, own.len() + borrowed.len(), borrowed.len()));
    }
    let entries: Vec<(u32, u32, u32, u32)> =
        blocks.iter().map(|(b, points, borrowed)| (b.len() as u32, *points as u32, *borrowed as u32, crc32fast::hash(b))).collect();
    let statics_entry = (static_block.len() as u32, statics.len() as u32, crc32fast::hash(&static_block));
    let mut out = encode_coded_index(grid, statics_entry, &entries);
    out.extend_from_slice(&static_block);
    for (b, _, _) in blocks {
        out.extend_from_slice(&b);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::cloud::CloudIndex;

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
            let back = index.decode_step(t, block, None, "clouds.bin").unwrap();
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
    fn a_coarser_grid_keeps_its_step_and_round_trips_within_half_of_it() {
        let grid = Grid::with_step(MIN, MAX, 0.001);
        // 4 m across at 1 mm: 4001 levels, 12 bits.
        assert_eq!(grid.position_bits, 12);
        let steps: Vec<(PointCloud, Vec<u32>)> = sample_clouds().into_iter().map(|c| (c, vec![])).collect();
        let bytes = encode_coded_clouds(&grid, &PointCloud::default(), &steps).unwrap();
        let index = CloudIndex::parse(&bytes, bytes.len() as u64, "clouds.bin").unwrap();
        assert_eq!(index.grid(), grid);
        for (t, (cloud, _)) in steps.iter().enumerate() {
            let e = index.steps[t];
            let back = index
                .decode_step(t, &bytes[e.offset as usize..(e.offset + e.byte_length()) as usize], Some(&PointCloud::default()), "c")
                .unwrap();
            let mut got: Vec<[u32; 3]> = back.positions_world.iter().map(|p| p.map(f32::to_bits)).collect();
            let mut want: Vec<[u32; 3]> =
                cloud.positions_world.iter().map(|p| grid.dequantise(grid.quantise(*p).unwrap()).map(f32::to_bits)).collect();
            got.sort_unstable();
            want.sort_unstable();
            assert_eq!(got, want);
            for p in &cloud.positions_world {
                let q = grid.dequantise(grid.quantise(*p).unwrap());
                for i in 0..3 {
                    let step = (MAX[i] - MIN[i]) / 4095.0;
                    assert!((q[i] - p[i]).abs() <= 0.5 * step + 1e-6, "{p:?} -> {q:?}");
                }
            }
        }
        assert_eq!(Grid::with_step(MIN, MAX, 0.0).position_bits, 16);
        assert_eq!(Grid::with_step(MIN, MAX, 10.0).position_bits, 1);
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
                        index.decode_step(t, block, None, "clouds.bin").is_err()
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
        bad[8] = 3;
        let err = CloudIndex::parse(&bad, bad.len() as u64, "clouds.bin").unwrap_err().to_string();
        assert!(err.contains("`version`"), "{err}");
        let err = CloudIndex::parse(&bytes, bytes.len() as u64 + 9, "clouds.bin").unwrap_err().to_string();
        assert!(err.contains("file length"), "{err}");
        let index = CloudIndex::parse(&bytes, bytes.len() as u64, "clouds.bin").unwrap();
        let err = index.decode_step(7, &[], None, "clouds.bin").unwrap_err().to_string();
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
