//! The coded point blocks of `clouds.bin` version 2: a block holds a step's own points and the
//! indices of the static points it borrows, entropy-coded (raw DEFLATE) after a transform that
//! makes them compressible:
//!
//! - own points sorted by the Morton code of their quantised position (neighbours in space are
//!   neighbours in the block), stored as LEB128 varints of the differences of the codes;
//! - their colors, quantised to the file's `color_bits`, as three planes, G, then R - G, then
//!   B - G, each value stored as its difference to the previous point's, all modulo
//!   `2^color_bits`;
//! - borrowed static indices, ascending, as varints of the gaps (`index - previous - 1`).
//!
//! Positions are cells of the file's grid ([`Grid`]); on the 16-bit grid of version 1 a coded
//! cloud decodes to the same points as a version 1 block of the same cloud (in another order).

use super::cloud_grid::Grid;
use super::error::{SceneError, SceneResult};
use super::limits::MAX_POINTS_PER_STEP;
use crate::points::PointCloud;

/// Bytes a varint of a Morton difference takes at most (48 bits).
const MAX_MORTON_VARINT: usize = 7;
/// Bytes a varint of an index gap takes at most (32 bits).
const MAX_INDEX_VARINT: usize = 5;

/// Spreads the 16 bits of `v` to every third bit.
fn spread(v: u16) -> u64 {
    let mut x = u64::from(v);
    x = (x | (x << 16)) & 0x0000_FF00_00FF;
    x = (x | (x << 8)) & 0x00F0_0F00_F00F;
    x = (x | (x << 4)) & 0x0C30_C30C_30C3;
    (x | (x << 2)) & 0x2492_4924_9249
}

/// Gathers every third bit of `x` into 16 bits.
fn gather(x: u64) -> u16 {
    let mut x = x & 0x2492_4924_9249;
    x = (x | (x >> 2)) & 0x0C30_C30C_30C3;
    x = (x | (x >> 4)) & 0x00F0_0F00_F00F;
    x = (x | (x >> 8)) & 0x0000_FF00_00FF;
    ((x | (x >> 16)) & 0xFFFF) as u16
}

fn morton(q: [u16; 3]) -> u64 {
    spread(q[0]) | (spread(q[1]) << 1) | (spread(q[2]) << 2)
}

fn unmorton(code: u64) -> [u16; 3] {
    [gather(code), gather(code >> 1), gather(code >> 2)]
}

fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// Reads a varint of at most `max_bytes` at `*at`.
fn get_varint(bytes: &[u8], at: &mut usize, max_bytes: usize) -> Option<u64> {
    let mut v = 0u64;
    for i in 0..max_bytes {
        let b = *bytes.get(*at)?;
        *at += 1;
        v |= u64::from(b & 0x7f) << (7 * i);
        if b & 0x80 == 0 {
            return Some(v);
        }
    }
    None
}

/// The bits a quantised color channel uses.
fn color_mask(grid: &Grid) -> u8 {
    (((1u32 << grid.color_bits) - 1) & 0xff) as u8
}

/// Channel `channel` of `c` as stored: green as is, red and blue minus green (mod 256), which
/// the three channels of natural colors share most of their changes through.
fn decorrelated(c: [u8; 3], channel: usize) -> u8 {
    if channel == 1 { c[1] } else { c[channel].wrapping_sub(c[1]) }
}

/// Codes a block: `own` points (quantised in the bounds, clamped onto the box) and the sorted,
/// distinct `borrowed` static indices. `field` names the block in errors.
pub fn encode_block(own: &PointCloud, borrowed: &[u32], grid: &Grid, field: &str) -> SceneResult<Vec<u8>> {
    const FILE: &str = "clouds.bin";
    if own.positions_world.len() != own.colors.len() {
        return Err(SceneError::invalid(FILE, field, "positions and colors differ in length"));
    }
    let mut points = Vec::with_capacity(own.len());
    for (k, (p, c)) in own.positions_world.iter().zip(&own.colors).enumerate() {
        let q = grid.quantise(*p).ok_or_else(|| SceneError::invalid(FILE, format!("{field}.points[{k}]"), "non-finite position"))?;
        points.push((morton(q), *c));
    }
    points.sort_unstable();
    let mut raw = Vec::with_capacity(own.len() * 6 + borrowed.len() * 2);
    let mut previous = 0u64;
    for &(code, _) in &points {
        put_varint(&mut raw, code - previous);
        previous = code;
    }
    let mask = color_mask(grid);
    for channel in [1, 0, 2] {
        let mut previous = 0u8;
        for (_, c) in &points {
            let value = decorrelated(c.map(|v| grid.quantise_color(v)), channel) & mask;
            raw.push(value.wrapping_sub(previous) & mask);
            previous = value;
        }
    }
    let mut next = 0u64;
    for (k, &i) in borrowed.iter().enumerate() {
        let Some(gap) = u64::from(i).checked_sub(next) else {
            return Err(SceneError::invalid(FILE, format!("{field}.borrowed[{k}]"), "static indices must ascend without repeats"));
        };
        put_varint(&mut raw, gap);
        next = u64::from(i) + 1;
    }
    Ok(miniz_oxide::deflate::compress_to_vec(&raw, 9))
}

/// Decodes a block of `own_count` points and `borrowed_count` static indices, each below
/// `static_count`. Returns the own points (in the block's order) and the indices. `file` and
/// `field` name the block in errors.
pub fn decode_block(
    bytes: &[u8],
    own_count: u32,
    borrowed_count: u32,
    static_count: u32,
    grid: &Grid,
    file: &str,
    field: &str,
) -> SceneResult<(PointCloud, Vec<u32>)> {
    let bad = |problem: &str| SceneError::invalid(file, field, problem);
    if own_count > MAX_POINTS_PER_STEP || borrowed_count > MAX_POINTS_PER_STEP {
        return Err(bad(&format!("{own_count} own and {borrowed_count} borrowed points: the limit is {MAX_POINTS_PER_STEP} each")));
    }
    let (own, borrowed) = (own_count as usize, borrowed_count as usize);
    // The most bytes the counts allow: a larger stream is refused while inflating.
    let limit = own * (MAX_MORTON_VARINT + 3) + borrowed * MAX_INDEX_VARINT;
    let raw = miniz_oxide::inflate::decompress_to_vec_with_limit(bytes, limit)
        .map_err(|e| bad(&format!("not a coded block ({:?})", e.status)))?;
    // Every point takes at least 4 bytes of the stream (a 1-byte varint and 3 colors), every
    // index 1: counts the stream cannot hold are refused before anything is allocated.
    if raw.len() < 4 * own + borrowed {
        return Err(bad(&format!("{} bytes cannot hold {own} points and {borrowed} indices", raw.len())));
    }
    let mut at = 0;
    let mut codes = Vec::with_capacity(own);
    let mut code = 0u64;
    for _ in 0..own {
        let delta = get_varint(&raw, &mut at, MAX_MORTON_VARINT).ok_or_else(|| bad("positions end early"))?;
        code = code.checked_add(delta).filter(|c| *c < 1 << 48).ok_or_else(|| bad("a position is outside the 16-bit grid"))?;
        codes.push(code);
    }
    let planes = raw.get(at..at + 3 * own).ok_or_else(|| bad("colors end early"))?;
    at += 3 * own;
    let mut cloud = PointCloud { positions_world: Vec::with_capacity(own), colors: vec![[0; 3]; own] };
    let mask = color_mask(grid);
    if planes.iter().any(|&d| d & !mask != 0) {
        return Err(bad(&format!("a color difference is outside {} bits", grid.color_bits)));
    }
    for (plane, channel) in [1, 0, 2].into_iter().enumerate() {
        let mut value = 0u8;
        for (k, d) in planes[plane * own..(plane + 1) * own].iter().enumerate() {
            value = value.wrapping_add(*d) & mask;
            // Green first (still quantised), so red and blue can add it back.
            let green = if channel == 1 { 0 } else { cloud.colors[k][1] };
            cloud.colors[k][channel] = value.wrapping_add(green) & mask;
        }
    }
    for color in &mut cloud.colors {
        *color = color.map(|q| grid.dequantise_color(q));
    }
    let top = (1u64 << (3 * grid.position_bits)) - 1;
    if codes.last().is_some_and(|&c| c > top) {
        return Err(bad(&format!("a position is outside the {}-bit grid", grid.position_bits)));
    }
    cloud.positions_world.extend(codes.iter().map(|&c| grid.dequantise(unmorton(c))));
    let mut indices = Vec::with_capacity(borrowed);
    let mut next = 0u64;
    for _ in 0..borrowed {
        let gap = get_varint(&raw, &mut at, MAX_INDEX_VARINT).ok_or_else(|| bad("borrowed indices end early"))?;
        let i = next + gap;
        if i >= u64::from(static_count) {
            return Err(bad(&format!("borrows static point {i}, but the static cloud has {static_count}")));
        }
        indices.push(i as u32);
        next = i + 1;
    }
    if at != raw.len() {
        return Err(bad("bytes left after the points"));
    }
    Ok((cloud, indices))
}

#[cfg(test)]
mod tests {
    use super::*;

    const GRID: Grid = Grid { bounds_min: [-1.0, 0.0, -1.0], bounds_max: [1.0, 2.0, 3.0], position_bits: 16, color_bits: 8 };

    fn cloud(n: usize) -> PointCloud {
        PointCloud {
            positions_world: (0..n).map(|i| [(i as f32 * 0.37).sin(), 1.0 + (i as f32 * 0.11).cos(), i as f32 / n as f32]).collect(),
            colors: (0..n).map(|i| [i as u8, (i * 3) as u8, 200]).collect(),
        }
    }

    #[test]
    fn morton_codes_round_trip() {
        for q in [[0, 0, 0], [65535, 65535, 65535], [1, 2, 3], [40000, 7, 65000]] {
            assert_eq!(unmorton(morton(q)), q);
        }
    }

    #[test]
    fn a_block_decodes_to_the_same_quantised_points_in_morton_order() {
        let own = cloud(500);
        let borrowed = [0, 1, 5, 6, 900, 4000];
        let bytes = encode_block(&own, &borrowed, &GRID, "steps[0]").unwrap();
        assert!(bytes.len() < 500 * 9, "{} bytes for 500 points", bytes.len());
        let (back, indices) = decode_block(&bytes, 500, 6, 4001, &GRID, "clouds.bin", "steps[0]").unwrap();
        assert_eq!(indices, borrowed);
        let key = |p: &[f32; 3], c: &[u8; 3]| (GRID.quantise(*p).unwrap(), *c);
        let mut expected: Vec<_> = own.positions_world.iter().zip(&own.colors).map(|(p, c)| key(p, c)).collect();
        let mut got: Vec<_> = back.positions_world.iter().zip(&back.colors).map(|(p, c)| key(p, c)).collect();
        expected.sort_unstable();
        got.sort_unstable();
        assert_eq!(got, expected);
        let empty = encode_block(&PointCloud::default(), &[], &GRID, "static").unwrap();
        assert_eq!(decode_block(&empty, 0, 0, 0, &GRID, "clouds.bin", "static").unwrap(), (PointCloud::default(), vec![]));
    }

    #[test]
    fn colors_on_fewer_bits_come_back_within_their_step_with_black_and_white_exact() {
        let grid = Grid { color_bits: 6, ..GRID };
        let mut own = cloud(300);
        own.colors[0] = [0, 0, 0];
        own.colors[1] = [255, 255, 255];
        let bytes = encode_block(&own, &[], &grid, "steps[0]").unwrap();
        let (back, _) = decode_block(&bytes, 300, 0, 0, &grid, "clouds.bin", "steps[0]").unwrap();
        let mut expected: Vec<_> = own.colors.iter().map(|c| c.map(|v| grid.dequantise_color(grid.quantise_color(v)))).collect();
        let mut got = back.colors.clone();
        expected.sort_unstable();
        got.sort_unstable();
        assert_eq!(got, expected);
        assert!(got.contains(&[0, 0, 0]) && got.contains(&[255, 255, 255]));
        for v in 0..=255u8 {
            assert!((i32::from(grid.dequantise_color(grid.quantise_color(v))) - i32::from(v)).abs() <= 4, "{v}");
        }
        // A 6-bit block read as 5-bit is refused, not misread.
        assert!(decode_block(&bytes, 300, 0, 0, &Grid { color_bits: 5, ..GRID }, "clouds.bin", "steps[0]").is_err());
    }

    #[test]
    fn counts_that_disagree_with_the_block_are_named_and_nothing_panics() {
        let bytes = encode_block(&cloud(50), &[3, 4], &GRID, "steps[2]").unwrap();
        for (own, borrowed, statics) in [(51, 2, 10), (49, 2, 10), (50, 3, 10), (50, 1, 10), (50, 2, 4), (u32::MAX, 0, 0)] {
            let err = decode_block(&bytes, own, borrowed, statics, &GRID, "clouds.bin", "steps[2]").unwrap_err().to_string();
            assert!(err.contains("clouds.bin: field `steps[2]`"), "{err}");
        }
        for cut in 0..bytes.len() {
            assert!(decode_block(&bytes[..cut], 50, 2, 10, &GRID, "clouds.bin", "steps[2]").is_err(), "cut at {cut}");
        }
        assert!(encode_block(&cloud(3), &[2, 2], &GRID, "steps[0]").is_err(), "repeated index");
        let nan = PointCloud { positions_world: vec![[f32::NAN, 0.0, 0.0]], colors: vec![[0; 3]] };
        assert!(encode_block(&nan, &[], &GRID, "steps[0]").is_err());
    }
}
