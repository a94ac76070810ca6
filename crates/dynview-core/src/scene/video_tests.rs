//! Video packages (format v2) on disk: frames come back exactly where they were written, in any
//! order of access; `verify` decodes everything; broken indexes and videos are named; format v1
//! packages are still read. Needs the `ffmpeg` program (`cargo xtask test` installs it).

use std::fs;
use std::path::Path;

use super::manifest::{FORMAT_VERSION_V1, Manifest};
use super::package::{ScenePackage, SceneWriter};
use super::testing::small_manifest;
use crate::metrics::psnr;
use crate::points::PointCloud;
use crate::raster::RgbRaster;

const W: u32 = 64;
const H: u32 = 48;

/// A smooth frame whose content moves with `t` (a bright square at `t`'s place), so that a
/// neighbouring frame differs clearly.
fn frame_for(camera: usize, t: u32) -> image::RgbImage {
    image::RgbImage::from_fn(W, H, |x, y| {
        let inside = (x as i64 - 6 * i64::from(t) - 4).abs() < 5 && (y as i64 - 20).abs() < 5;
        let base = [(x * 3 + camera as u32 * 40) as u8, (y * 4) as u8, 90];
        image::Rgb(if inside { [240, 240, 60] } else { base })
    })
}

fn psnr_rgb8(a: &image::RgbImage, b: &image::RgbImage) -> f64 {
    psnr(&RgbRaster::from_rgb8(a), &RgbRaster::from_rgb8(b))
}

fn sized(mut m: Manifest) -> Manifest {
    for c in &mut m.cameras {
        (c.width, c.height) = (W, H);
    }
    m
}

fn video_manifest(cameras: usize, steps: u32, keyframe_interval: u32) -> Manifest {
    let mut m = sized(small_manifest(cameras, steps));
    m.set_video_frames(keyframe_interval);
    m
}

fn write_video(dir: &Path, cameras: usize, steps: u32, keyframe_interval: u32) {
    let mut writer = SceneWriter::create(dir, video_manifest(cameras, steps, keyframe_interval)).unwrap();
    for t in 0..steps {
        for c in 0..cameras {
            writer.write_frame(c, t, &frame_for(c, t)).unwrap();
        }
        writer.push_cloud(&PointCloud { positions_world: vec![[0.0; 3]], colors: vec![[1, 2, 3]] }).unwrap();
    }
    writer.finish().unwrap();
}

#[test]
fn every_frame_comes_back_as_itself_in_any_order() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    write_video(&dir, 2, 9, 4);
    let package = ScenePackage::open(&dir).unwrap();
    assert_eq!(package.manifest().version, 2);
    let index = package.frame_index().unwrap();
    let keys: Vec<bool> = index.cameras[0].frames.iter().map(|f| f.key).collect();
    assert_eq!(keys.iter().filter(|&&k| k).count(), 3, "keyframes every 4 frames: {keys:?}");
    // Random access (scrubbing back and forth) decodes the same pixels as a fresh reader going
    // forward, and each frame is closest to its own original.
    let sequential: Vec<_> = (0..9).map(|t| ScenePackage::open(&dir).unwrap().read_frame(1, t).unwrap().to_rgb8()).collect();
    for t in [6, 2, 8, 0, 7, 3] {
        let frame = package.read_frame(1, t).unwrap().to_rgb8();
        assert_eq!(frame, sequential[t as usize], "frame {t}");
        let own = psnr_rgb8(&frame, &frame_for(1, t));
        assert!(own > 30.0, "frame {t}: {own:.1} dB against its original");
        for other in [t.wrapping_sub(1), t + 1].into_iter().filter(|&o| o < 9) {
            assert!(psnr_rgb8(&frame, &frame_for(1, other)) < own - 3.0, "frame {t} looks like frame {other}");
        }
    }
    let mut steps = Vec::new();
    package.verify(|done, total| steps.push((done, total))).unwrap();
    assert_eq!(steps.last(), Some(&(9 + 2 * 9, 9 + 2 * 9)));
    assert!(!dir.join("frames").join("cam0").exists(), "no per-frame folders in a video package");
}

#[test]
fn broken_indexes_and_videos_are_named() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    write_video(&dir, 1, 5, 2);
    let index = dir.join("frames.idx");
    let good = fs::read(&index).unwrap();
    let video = dir.join("frames").join("cam0.ivf");
    let good_video = fs::read(&video).unwrap();
    let open_error = || ScenePackage::open(&dir).unwrap_err().to_string();

    let mut flipped = good.clone();
    flipped[30] ^= 4;
    fs::write(&index, &flipped).unwrap();
    assert!(open_error().contains("frames.idx: field `crc32`"), "{}", open_error());
    fs::write(&index, &good[..good.len() - 4]).unwrap();
    assert!(open_error().contains("frames.idx"), "{}", open_error());
    fs::write(&index, &good).unwrap();

    fs::write(&video, &good_video[..good_video.len() - 3]).unwrap();
    assert!(open_error().contains("cam0.ivf"), "{}", open_error());
    // Same length, but a frame header that disagrees with the index: named when read.
    let mut lying = good_video.clone();
    lying[32] ^= 1;
    fs::write(&video, &lying).unwrap();
    let package = ScenePackage::open(&dir).unwrap();
    let err = package.read_frame(0, 1).unwrap_err().to_string();
    assert!(err.contains("cam0.ivf") && err.contains("frame 0"), "{err}");
    assert!(package.verify(|_, _| {}).is_err());
}

#[test]
fn video_frames_must_be_written_in_time_order() {
    let tmp = tempfile::tempdir().unwrap();
    let writer = SceneWriter::create(tmp.path().join("scene"), video_manifest(1, 3, 2)).unwrap();
    writer.write_frame(0, 0, &frame_for(0, 0)).unwrap();
    let err = writer.write_frame(0, 2, &frame_for(0, 2)).unwrap_err().to_string();
    assert!(err.contains("cam0.ivf") && err.contains("(frame order)"), "{err}");
    drop(writer);
    assert!(!tmp.path().join("scene").exists(), "an abandoned write leaves no package");
}

#[test]
fn version_1_packages_are_still_read() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    let mut m = sized(small_manifest(1, 2));
    m.version = FORMAT_VERSION_V1;
    let mut writer = SceneWriter::create(&dir, m).unwrap();
    for t in 0..2 {
        writer.write_frame(0, t, &frame_for(0, t)).unwrap();
        writer.push_cloud(&PointCloud::default()).unwrap();
    }
    writer.finish().unwrap();
    let package = ScenePackage::open(&dir).unwrap();
    assert_eq!(package.manifest().version, 1);
    assert_eq!(package.read_frame(0, 1).unwrap().to_rgb8(), frame_for(0, 1));
    assert!(package.frame_index().is_none());
}
