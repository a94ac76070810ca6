//! Background plates on a synthetic still camera: a textured static background and a square
//! that stands still for 40% of the frames, then moves across. The plate is the background,
//! also where the square stood; the estimator's memory does not grow with the frames; the
//! result does not depend on the number of threads.

use dynview_sfm::dense::{Plate, PlateEstimator, PlateOptions};
use image::{Rgb, RgbImage};

const WIDTH: u32 = 64;
const HEIGHT: u32 = 48;
const FRAMES: u32 = 50;
/// Frames the square stands still at the start.
const STILL_FRAMES: u32 = 20;
const SQUARE_PX: u32 = 12;
/// Where the square stands still (top-left corner).
const STILL_AT: (u32, u32) = (8, 8);
const TOLERANCE_LEVELS: u8 = 3;

/// The static background: a texture in 20..=160 per channel.
fn background(x: u32, y: u32) -> Rgb<u8> {
    Rgb([(20 + (x * 37 + y * 11) % 141) as u8, (20 + (x * x + y * 29) % 141) as u8, (20 + (x * 13 + y * y * 7) % 141) as u8])
}

/// The square's top-left corner at frame `t`: still, then 3 px per frame to the right and 2 px
/// down, so that it leaves its still place within 4 frames (hidden 24 of 50 frames at most).
fn square_at(t: u32) -> (u32, u32) {
    let moved = t.saturating_sub(STILL_FRAMES - 1);
    (STILL_AT.0 + 3 * moved, STILL_AT.1 + 2 * moved)
}

fn frame(t: u32) -> RgbImage {
    let (sx, sy) = square_at(t);
    RgbImage::from_fn(WIDTH, HEIGHT, |x, y| {
        if (sx..sx + SQUARE_PX).contains(&x) && (sy..sy + SQUARE_PX).contains(&y) {
            // A bright texture, far (> 60 levels) from the background everywhere.
            Rgb([(220 + (x + y) % 36) as u8, (230 + x % 26) as u8, (225 + y % 31) as u8])
        } else {
            background(x, y)
        }
    })
}

fn matches_background(plate: &Plate, x: u32, y: u32) -> bool {
    plate.image.get_pixel(x, y).0.iter().zip(background(x, y).0).all(|(p, b)| p.abs_diff(b) <= TOLERANCE_LEVELS)
}

fn estimate(threads: usize) -> (Plate, usize, usize) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
    pool.install(|| {
        let mut estimator = PlateEstimator::new(WIDTH, HEIGHT, PlateOptions::default()).expect("estimator");
        let mut bytes_at_10 = 0;
        for t in 0..FRAMES {
            estimator.push(&frame(t)).expect("push");
            if t + 1 == 10 {
                bytes_at_10 = estimator.state_bytes();
            }
        }
        assert_eq!(estimator.frames(), u64::from(FRAMES));
        (estimator.plate(), bytes_at_10, estimator.state_bytes())
    })
}

#[test]
fn the_plate_is_the_background_also_where_the_square_stood_still() {
    let (plate, bytes_at_10, bytes_at_50) = estimate(2);
    let good = (0..HEIGHT).flat_map(|y| (0..WIDTH).map(move |x| (x, y))).filter(|&(x, y)| matches_background(&plate, x, y)).count();
    let share = good as f64 / f64::from(WIDTH * HEIGHT);
    assert!(share >= 0.99, "only {:.2}% of the pixels match the background", share * 100.0);

    // Where the square stood still for 40% of the frames (and then moved off): every pixel.
    let still = (STILL_AT.1..STILL_AT.1 + SQUARE_PX).flat_map(|y| (STILL_AT.0..STILL_AT.0 + SQUARE_PX).map(move |x| (x, y)));
    for (x, y) in still.clone() {
        assert!(matches_background(&plate, x, y), "({x}, {y}): {:?} vs {:?}", plate.image.get_pixel(x, y), background(x, y));
    }
    // There the background was hidden 40% of the time: lower confidence than in a corner that
    // nothing ever hid.
    let at = |x: u32, y: u32| plate.confidence[(y * WIDTH + x) as usize];
    let clear = at(WIDTH - 1, 0);
    assert!((clear - 1.0).abs() < 1e-6, "{clear}");
    for (x, y) in still {
        assert!(at(x, y) <= 0.62, "({x}, {y}): {}", at(x, y));
    }

    assert!(bytes_at_10 > 0);
    assert_eq!(bytes_at_10, bytes_at_50, "the state grew with the frames");
}

#[test]
fn the_plate_does_not_depend_on_the_thread_count() {
    assert_eq!(estimate(1).0, estimate(4).0);
}
