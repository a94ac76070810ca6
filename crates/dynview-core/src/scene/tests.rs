//! Package round trips and corruption tests (property tests: no input may panic a reader).

use std::fs;

use proptest::prelude::*;

use super::cloud::{self, CloudIndex};
use super::cloud_encode;
use super::cloud_grid::Grid;
use super::manifest::Manifest;
use super::package::{ScenePackage, SceneWriter, decode_frame};
use super::testing::small_manifest;
use super::{FrameFormat, SceneError};
use crate::points::PointCloud;

fn cloud_for_step(t: u32) -> PointCloud {
    let n = 5 + t as usize * 3;
    PointCloud {
        positions_world: (0..n).map(|i| [i as f32 * 0.1 - 1.0, t as f32 * 0.2, 0.5]).collect(),
        colors: (0..n).map(|i| [i as u8, t as u8, 200]).collect(),
    }
}

fn frame_for(camera: usize, t: u32) -> image::RgbImage {
    image::RgbImage::from_fn(8, 6, |x, y| image::Rgb([(x * 30) as u8, (y * 40) as u8, (camera * 50 + t as usize * 7) as u8]))
}

fn write_small(dir: &std::path::Path, cameras: usize, steps: u32) -> Manifest {
    let mut writer = SceneWriter::create(dir, small_manifest(cameras, steps)).unwrap();
    for t in 0..steps {
        for c in 0..cameras {
            writer.write_frame(c, t, &frame_for(c, t)).unwrap();
        }
        writer.push_cloud(&cloud_for_step(t)).unwrap();
    }
    writer.finish().unwrap()
}

#[test]
fn package_round_trip() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    let written = write_small(&dir, 3, 4);
    let package = ScenePackage::open(&dir).unwrap();
    assert_eq!(package.manifest(), &written);
    assert_eq!(package.time_step_count(), 4);
    for t in 0..4 {
        let cloud = package.read_cloud(t).unwrap();
        assert_eq!(cloud.colors, cloud_for_step(t).colors);
        for c in 0..3 {
            let frame = package.read_frame(c, t).unwrap();
            assert_eq!(frame.to_rgb8(), frame_for(c, t)); // PNG is lossless
        }
    }
    package.verify(|_, _| {}).unwrap();
    let summary = package.summary().unwrap();
    assert_eq!(summary.points_per_step, vec![5, 8, 11, 14]);
    assert!(summary.to_string().contains("38 in all"));
    // No staging folder is left behind.
    let leftovers: Vec<_> = fs::read_dir(tmp.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(leftovers, vec![std::ffi::OsString::from("scene")]);
}

#[test]
fn a_cameras_color_balance_reaches_the_renderer_and_nothing_else() {
    use crate::color_balance::ColorTransform;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    let mut manifest = small_manifest(2, 1);
    let balance = ColorTransform { gain: [0.5, 1.0, 1.0], offset: [0.1, 0.0, -0.1] };
    manifest.cameras[1].color_balance = Some(balance);
    let mut writer = SceneWriter::create(&dir, manifest).unwrap();
    for c in 0..2 {
        writer.write_frame(c, 0, &frame_for(c, 0)).unwrap();
    }
    writer.push_cloud(&cloud_for_step(0)).unwrap();
    writer.finish().unwrap();
    let package = ScenePackage::open(&dir).unwrap();
    assert_eq!(package.manifest().cameras[1].color_balance, Some(balance));
    // `dynview info` says which cameras are balanced (the largest change: red at white,
    // 0.5 + 0.1 - 1, 102 code values); one pose is a path of +0, not "-0.000".
    let summary = package.summary().unwrap().to_string();
    let lines: Vec<&str> = summary.lines().filter(|l| l.starts_with("  cam")).collect();
    assert!(lines[1].ends_with("colors balanced (up to 102 code values)") && !lines[0].contains("balanced"), "{summary}");
    assert!(lines.iter().all(|l| l.contains("path 0.000")), "{summary}");
    let inputs = package.time_step_inputs(0, 2).unwrap();
    // As stored, the frames are the cameras' own; the renderer sees camera 1 balanced.
    for c in 0..2 {
        let stored = package.read_frame(c, 0).unwrap();
        assert_eq!(stored.to_rgb8(), frame_for(c, 0));
        let expected: Vec<_> =
            if c == 1 { stored.data.iter().map(|&px| balance.apply(px).map(|v| v.clamp(0.0, 1.0))).collect() } else { stored.data.clone() };
        assert_eq!(inputs.views[c].levels[0].data, expected);
    }
}

#[test]
fn plates_reach_the_renderer_balanced_with_the_steps_static_points() {
    use crate::color_balance::ColorTransform;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    let mut manifest = small_manifest(2, 2);
    manifest.version = super::manifest::FORMAT_VERSION;
    let balance = ColorTransform { gain: [0.5, 1.0, 1.0], offset: [0.1, 0.0, -0.1] };
    manifest.cameras[0].color_balance = Some(balance);
    let mut writer = SceneWriter::create(&dir, manifest).unwrap();
    // A flat plate (JPEG keeps it exact) for camera 0 only.
    let plate = image::RgbImage::from_pixel(8, 6, image::Rgb([200, 100, 40]));
    writer.write_plate(0, &plate).unwrap();
    let wrong = writer.write_plate(1, &image::RgbImage::new(4, 4)).unwrap_err().to_string();
    assert!(wrong.contains("plates/") && wrong.contains("expected 8x6"), "{wrong}");
    writer.set_static_cloud(&cloud_for_step(3)).unwrap();
    for t in 0..2 {
        for c in 0..2 {
            writer.write_frame(c, t, &frame_for(c, t)).unwrap();
        }
        writer.push_cloud_borrowing(&cloud_for_step(t), &[1, 4, 6]).unwrap();
    }
    writer.finish().unwrap();
    let package = ScenePackage::open(&dir).unwrap();
    assert!(package.manifest().cameras[0].plate && !package.manifest().cameras[1].plate);
    let inputs = package.time_step_inputs(1, 2).unwrap();
    assert_eq!(inputs.static_points, 3);
    assert_eq!(inputs.cloud.len(), cloud_for_step(1).len() + 3);
    let seen = &inputs.views[0].plate.as_ref().expect("camera 0's plate")[0];
    let expected = balance.apply([200.0 / 255.0, 100.0 / 255.0, 40.0 / 255.0]).map(|v| v.clamp(0.0, 1.0));
    assert!(seen.data.iter().all(|p| (0..3).all(|k| (p[k] - expected[k]).abs() < 2.0 / 255.0)), "{:?}", seen.data[0]);
    assert!(inputs.views[1].plate.is_none());
    // One pyramid of the plate, shared by every step (the GPU keeps it uploaded); another depth
    // builds its own.
    let first = package.time_step_inputs(0, 2).unwrap();
    assert!(std::sync::Arc::ptr_eq(first.views[0].plate.as_ref().unwrap(), inputs.views[0].plate.as_ref().unwrap()));
    let deeper = package.time_step_inputs(0, 3).unwrap();
    assert_eq!(deeper.views[0].plate.as_ref().unwrap().len(), 3);
    package.verify(|_, _| {}).unwrap();
    // A repacked package keeps its plates (and claims no other).
    let repacked = tmp.path().join("repacked");
    super::repack::repack(&package, &repacked, None, false, |_, _| {}).unwrap();
    let again = ScenePackage::open(&repacked).unwrap();
    assert_eq!(again.manifest().cameras.iter().map(|c| c.plate).collect::<Vec<_>>(), [true, false]);
    assert_eq!(again.time_step_inputs(1, 2).unwrap().static_points, 3);
    let stored = again.stored_plate(0).unwrap().expect("the plate").to_rgb8();
    assert!(stored.pixels().all(|p| p.0.iter().zip([200, 100, 40]).all(|(&a, b): (&u8, i32)| (i32::from(a) - b).abs() <= 2)));
    // A plate file of the wrong size is an error naming it.
    let path = dir.join("plates").join("cam0.jpg");
    let mut bytes = Vec::new();
    image::RgbImage::new(4, 4).write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Jpeg).unwrap();
    fs::write(&path, bytes).unwrap();
    let package = ScenePackage::open(&dir).unwrap();
    let error = package.time_step_inputs(0, 2).unwrap_err().to_string();
    assert!(error.contains("cam0.jpg"), "{error}");
}

#[test]
fn a_color_balance_out_of_range_is_named() {
    for (field, gain, offset) in
        [("gain[1]", f32::NAN, 0.0), ("gain[1]", 0.0, 0.0), ("gain[1]", 40.0, 0.0), ("offset[1]", 1.0, f32::INFINITY)]
    {
        let mut manifest = small_manifest(2, 1);
        let mut balance = crate::color_balance::ColorTransform::IDENTITY;
        balance.gain[1] = gain;
        balance.offset[1] = offset;
        manifest.cameras[1].color_balance = Some(balance);
        let err = manifest.validate("scene.json").unwrap_err();
        assert!(err.to_string().contains(&format!("cameras[1].color_balance.{field}")), "{err}");
    }
}

#[test]
fn reading_one_step_ignores_the_others() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    write_small(&dir, 1, 3);
    let package = ScenePackage::open(&dir).unwrap();
    // Corrupt step 0's block: step 2 still reads, step 0 reports its checksum.
    let path = dir.join("clouds.bin");
    let mut bytes = fs::read(&path).unwrap();
    let first = package.cloud_index().steps[0].offset as usize;
    bytes[first] ^= 0xff;
    fs::write(&path, bytes).unwrap();
    assert!(package.read_cloud(2).is_ok());
    let err = package.read_cloud(0).unwrap_err();
    assert!(matches!(&err, SceneError::Checksum { field, .. } if field == "steps[0].crc32"), "{err}");
}

#[test]
fn writer_replaces_packages_but_not_other_folders() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    write_small(&dir, 2, 2);
    write_small(&dir, 1, 3);
    assert_eq!(ScenePackage::open(&dir).unwrap().time_step_count(), 3);

    let precious = tmp.path().join("precious");
    fs::create_dir(&precious).unwrap();
    fs::write(precious.join("thesis.tex"), "keep me").unwrap();
    let err = SceneWriter::create(&precious, small_manifest(1, 1)).unwrap_err();
    assert!(matches!(err, SceneError::OutputNotAScene { .. }));
    assert_eq!(fs::read_to_string(precious.join("thesis.tex")).unwrap(), "keep me");
}

#[test]
fn abandoned_or_incomplete_write_keeps_the_old_package() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    write_small(&dir, 2, 2);
    {
        let mut writer = SceneWriter::create(&dir, small_manifest(2, 5)).unwrap();
        writer.push_cloud(&cloud_for_step(0)).unwrap();
        // Dropped without finish.
    }
    let mut writer = SceneWriter::create(&dir, small_manifest(1, 1)).unwrap();
    writer.push_cloud(&cloud_for_step(0)).unwrap();
    let err = writer.finish().unwrap_err();
    assert!(err.to_string().contains("frame was never written"), "{err}");
    assert_eq!(ScenePackage::open(&dir).unwrap().time_step_count(), 2);
    assert_eq!(fs::read_dir(tmp.path()).unwrap().count(), 1);
}

#[test]
fn open_names_the_broken_part() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    write_small(&dir, 2, 2);
    let clouds = dir.join("clouds.bin");
    let good = fs::read(&clouds).unwrap();

    fs::write(&clouds, &good[..good.len() - 1]).unwrap();
    let err = ScenePackage::open(&dir).unwrap_err().to_string();
    assert!(err.contains("clouds.byte_length"), "{err}");

    fs::write(&clouds, &good).unwrap();
    let manifest_path = dir.join("scene.json");
    let text = fs::read_to_string(&manifest_path).unwrap();
    fs::write(&manifest_path, text.replacen("\"version\": 2", "\"version\": 7", 1)).unwrap();
    let err = ScenePackage::open(&dir).unwrap_err().to_string();
    assert!(err.contains("`version`") && err.contains("scene.json"), "{err}");

    fs::write(&manifest_path, &text).unwrap();
    fs::remove_file(dir.join("frames/cam1/00001.png")).unwrap();
    let package = ScenePackage::open(&dir).unwrap();
    let err = package.verify(|_, _| {}).unwrap_err().to_string();
    assert!(err.contains("cam1/00001.png"), "{err}");
}

#[test]
fn frame_of_wrong_size_is_rejected_before_decoding() {
    let img = image::RgbImage::new(16, 16);
    let bytes = super::package::encode_frame(&img, FrameFormat::Png, "x.png").unwrap();
    let err = decode_frame(&bytes, FrameFormat::Png, 8, 6, "x.png").unwrap_err().to_string();
    assert!(err.contains("16x16"), "{err}");
}

fn small_clouds_file() -> Vec<u8> {
    let clouds: Vec<PointCloud> = (0..3).map(cloud_for_step).collect();
    cloud_encode::encode_clouds([-2.0, -1.0, -2.0], [2.0, 2.0, 2.0], &clouds).unwrap()
}

/// A version 2 file: a static cloud of 7 points, three steps borrowing some of them.
fn small_coded_clouds_file() -> Vec<u8> {
    let steps: Vec<(PointCloud, Vec<u32>)> = (0..3).map(|t| (cloud_for_step(t), (0..7).filter(|i| i % (t + 2) == 0).collect())).collect();
    cloud_encode::encode_coded_clouds(&Grid::full([-2.0, -1.0, -2.0], [2.0, 2.0, 2.0]), &cloud_for_step(1), &steps).unwrap()
}

fn block<'a>(bytes: &'a [u8], e: &cloud::StepEntry) -> &'a [u8] {
    let end = (e.offset + e.byte_length()).min(bytes.len() as u64) as usize;
    &bytes[(e.offset as usize).min(end)..end]
}

/// Parses and decodes every step; any error is fine, a panic is not.
fn parse_all(bytes: &[u8], claimed_len: u64) -> Result<usize, SceneError> {
    let index = CloudIndex::parse(bytes, claimed_len, "clouds.bin")?;
    let statics = match &index.static_block {
        Some(e) => Some(index.decode_static(block(bytes, e), "clouds.bin")?),
        None => None,
    };
    let mut points = 0;
    for (t, e) in index.steps.iter().enumerate() {
        points += index.decode_step(t, block(bytes, e), statics.as_ref(), "clouds.bin")?.len();
    }
    Ok(points)
}

#[test]
fn coded_clouds_decode_to_the_plain_ones() {
    let plain = small_clouds_file();
    let coded = small_coded_clouds_file();
    let (p, c) = (CloudIndex::parse(&plain, plain.len() as u64, "a").unwrap(), CloudIndex::parse(&coded, coded.len() as u64, "b").unwrap());
    let statics = c.decode_static(block(&coded, &c.static_block.unwrap()), "b").unwrap();
    assert_eq!(statics.len(), cloud_for_step(1).len());
    for t in 0..3 {
        let from_plain = p.decode_step(t, block(&plain, &p.steps[t]), None, "a").unwrap();
        let from_coded = c.decode_step(t, block(&coded, &c.steps[t]), Some(&statics), "b").unwrap();
        let borrowed: Vec<usize> = (0..7).filter(|i| i % (t + 2) == 0).collect();
        assert_eq!(from_coded.len(), from_plain.len() + borrowed.len());
        let key = |cloud: &PointCloud, i: usize| (cloud.positions_world[i].map(f32::to_bits), cloud.colors[i]);
        let mut own: Vec<_> = (0..from_plain.len()).map(|i| key(&from_coded, i)).collect();
        let mut expected: Vec<_> = (0..from_plain.len()).map(|i| key(&from_plain, i)).collect();
        own.sort_unstable();
        expected.sort_unstable();
        assert_eq!(own, expected, "step {t}: the same points, in Morton order");
        for (k, &i) in borrowed.iter().enumerate() {
            assert_eq!(key(&from_coded, from_plain.len() + k), key(&statics, i), "step {t}: borrowed point {k}");
        }
    }
    assert!(c.decode_step(0, block(&coded, &c.steps[0]), None, "b").unwrap_err().to_string().contains("static"));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic_the_clouds_parser(bytes in proptest::collection::vec(any::<u8>(), 0..400), extra in 0u64..1_000_000, coded in any::<bool>()) {
        let mut bytes = bytes;
        if coded && bytes.len() >= 12 {
            // A version 2 header, so the random rest reaches the coded parser.
            bytes[..8].copy_from_slice(cloud::CLOUDS_MAGIC);
            bytes[8..12].copy_from_slice(&2u32.to_le_bytes());
        }
        let _ = parse_all(&bytes, bytes.len() as u64);
        let _ = parse_all(&bytes, bytes.len() as u64 + extra);
    }

    #[test]
    fn mutated_clouds_files_are_rejected(edits in proptest::collection::vec((any::<prop::sample::Index>(), 1u8..=255), 1..6), coded in any::<bool>()) {
        let good = if coded { small_coded_clouds_file() } else { small_clouds_file() };
        let mut bad = good.clone();
        for (at, xor) in edits {
            let i = at.index(bad.len());
            bad[i] ^= xor;
        }
        if bad != good {
            prop_assert!(parse_all(&bad, bad.len() as u64).is_err());
        }
    }

    #[test]
    fn absurd_coded_counts_are_rejected_before_allocating(point_count in 1u32.., borrowed in 0u32.., length in 1u32..100_000) {
        // Checksums right, counts absurd: the index or the block says so, nothing allocates.
        let bytes = cloud_encode::encode_coded_index(&Grid::full([0.0; 3], [1.0; 3]), (0, 0, 0), &[(length, point_count, borrowed, 0)]);
        let claimed = bytes.len() as u64 + u64::from(length);
        let mut file = bytes.clone();
        file.resize(claimed as usize, 0);
        prop_assert!(parse_all(&file, claimed).is_err());
    }

    #[test]
    fn absurd_point_counts_are_rejected_before_allocating(point_count in 1u32..) {
        // A header whose checksum is right but whose block lies past the end of the file.
        let bytes = cloud_encode::encode_index([0.0; 3], [1.0; 3], &[(point_count, 0)]);
        let err = CloudIndex::parse(&bytes, bytes.len() as u64, "clouds.bin").unwrap_err().to_string();
        prop_assert!(err.contains("`steps[0].point_count`"), "{}", err);
    }

    #[test]
    fn absurd_step_counts_are_rejected(step_count in (super::limits::MAX_TIME_STEPS + 1)..) {
        let mut bytes = cloud_encode::encode_index([0.0; 3], [1.0; 3], &[(0, 0)]);
        bytes[12..16].copy_from_slice(&step_count.to_le_bytes());
        let err = CloudIndex::parse(&bytes, bytes.len() as u64, "clouds.bin").unwrap_err().to_string();
        prop_assert!(err.contains("`step_count`"), "{}", err);
    }

    #[test]
    fn random_bytes_never_panic_the_manifest_parser(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let _ = Manifest::from_json_slice(&bytes, "scene.json");
    }

    #[test]
    fn mutated_manifest_numbers_are_caught_or_valid(path_pick in any::<prop::sample::Index>(), value in prop_oneof![
        any::<f64>(), Just(1e308), Just(-0.0), Just(0.0), Just(4.0e9), Just(-1.0)
    ]) {
        let manifest = small_manifest(2, 3);
        let mut json: serde_json::Value = serde_json::from_str(&manifest.to_json_pretty()).unwrap();
        let mut leaves = Vec::new();
        collect_number_paths(&json, String::new(), &mut leaves);
        let pointer = &leaves[path_pick.index(leaves.len())];
        if let Some(n) = serde_json::Number::from_f64(value) {
            *json.pointer_mut(pointer).unwrap() = serde_json::Value::Number(n);
        }
        let text = json.to_string();
        if let Ok(parsed) = Manifest::from_json_slice(text.as_bytes(), "scene.json") {
            prop_assert!(parsed.validate("scene.json").is_ok());
        }
    }

    #[test]
    fn random_bytes_never_panic_the_frame_decoder(bytes in proptest::collection::vec(any::<u8>(), 0..600), jpeg in any::<bool>()) {
        let format = if jpeg { FrameFormat::Jpeg } else { FrameFormat::Png };
        let _ = decode_frame(&bytes, format, 8, 6, "frame");
    }
}

fn collect_number_paths(value: &serde_json::Value, prefix: String, out: &mut Vec<String>) {
    match value {
        serde_json::Value::Number(_) => out.push(prefix),
        serde_json::Value::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                collect_number_paths(v, format!("{prefix}/{i}"), out);
            }
        }
        serde_json::Value::Object(map) => {
            for (k, v) in map {
                collect_number_paths(v, format!("{prefix}/{k}"), out);
            }
        }
        _ => {}
    }
}
