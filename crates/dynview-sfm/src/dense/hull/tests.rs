use super::*;
use crate::dense::Plate;
use dynview_core::{Intrinsics, Rigid3};
use glam::DVec3;
use image::RgbImage;

const SPHERE_CENTER: DVec3 = DVec3::new(0.0, 0.0, 3.0);
const SPHERE_RADIUS_M: f64 = 0.35;
/// The wall behind the sphere: the plane z = 6.
const WALL_Z_M: f64 = 6.0;
const SIZE_PX: (u32, u32) = (160, 120);

/// Five cameras 3 m from the sphere, from -40 to 40 degrees around it.
fn cameras() -> Vec<Camera> {
    [-40.0f64, -20.0, 0.0, 20.0, 40.0]
        .iter()
        .map(|deg| {
            let a = deg.to_radians();
            let eye = SPHERE_CENTER + DVec3::new(3.0 * a.sin(), 0.3, -3.0 * a.cos());
            Camera {
                intrinsics: Intrinsics { fx: 150.0, fy: 150.0, cx: 79.5, cy: 59.5 },
                camera_from_world: Rigid3::camera_from_world_looking_at(eye, SPHERE_CENTER, DVec3::Y),
                width_px: SIZE_PX.0,
                height_px: SIZE_PX.1,
            }
        })
        .collect()
}

/// Distance along the unit ray `(origin, dir)` to the sphere, if it hits.
fn hit_sphere(origin: DVec3, dir: DVec3) -> Option<f64> {
    let oc = origin - SPHERE_CENTER;
    let b = oc.dot(dir);
    let disc = b * b - (oc.length_squared() - SPHERE_RADIUS_M * SPHERE_RADIUS_M);
    (disc >= 0.0).then(|| -b - disc.sqrt()).filter(|t| *t > 0.0)
}

fn wall_color(p: DVec3) -> [u8; 3] {
    let f = |v: f64| (255.0 * v).round() as u8;
    [f(0.5 + 0.4 * (3.0 * p.x).sin()), f(0.5 + 0.4 * (2.0 * p.y).cos()), 128]
}

/// Half the side (m) of the cube in place of the sphere in [`hull_of_cube`]: its front face
/// lies at z = 2.7, facing the middle camera.
const CUBE_HALF_M: f64 = 0.3;

/// Distance along the unit ray `(origin, dir)` to the axis-aligned cube around the sphere's
/// centre, if it hits (the slab test).
fn hit_cube(origin: DVec3, dir: DVec3) -> Option<f64> {
    let (lo, hi) = (SPHERE_CENTER - DVec3::splat(CUBE_HALF_M), SPHERE_CENTER + DVec3::splat(CUBE_HALF_M));
    let (t1, t2) = ((lo - origin) / dir, (hi - origin) / dir);
    let (near, far) = (t1.min(t2).max_element(), t1.max(t2).min_element());
    (near <= far && near > 0.0).then_some(near)
}

/// Where a ray from `origin` along the unit `dir` first meets an object.
type Hit = fn(DVec3, DVec3) -> Option<f64>;

/// The camera's image of the wall, and of the plain sphere in front of it when `sphere`.
fn render(camera: &Camera, sphere: bool) -> RgbImage {
    render_with(camera, sphere.then_some(hit_sphere as Hit))
}

/// The camera's image of the wall, and of the plain object `hit` meets in front of it.
fn render_with(camera: &Camera, hit: Option<Hit>) -> RgbImage {
    let eye = camera.center_world();
    RgbImage::from_fn(SIZE_PX.0, SIZE_PX.1, |x, y| {
        let dir = (camera.unproject_world(DVec2::new(f64::from(x), f64::from(y)), 1.0) - eye).normalize();
        if hit.is_some_and(|hit| hit(eye, dir).is_some()) {
            return image::Rgb([200, 30, 30]);
        }
        let t = (WALL_Z_M - eye.z) / dir.z;
        image::Rgb(wall_color(eye + t * dir))
    })
}

fn plate(camera: &Camera) -> Plate {
    Plate { image: render(camera, false), confidence: vec![1.0; (SIZE_PX.0 * SIZE_PX.1) as usize], frames: 10, others: Vec::new() }
}

/// Points on the wall, as the static cloud would have them.
fn wall_points() -> PointCloud {
    let mut cloud = PointCloud::default();
    for i in 0..40 {
        for j in 0..30 {
            cloud.positions_world.push([-4.0 + 0.2 * i as f32, -3.0 + 0.2 * j as f32, WALL_Z_M as f32]);
            cloud.colors.push([128, 128, 128]);
        }
    }
    cloud
}

/// True depth of the sphere along the camera's pixel ray (z-depth), if it is there.
fn sphere_depth(camera: &Camera, pixel: DVec2) -> Option<f64> {
    let eye = camera.center_world();
    let dir = (camera.unproject_world(pixel, 1.0) - eye).normalize();
    let t = hit_sphere(eye, dir)?;
    camera.project_world(eye + t * dir).map(|(_, z)| z)
}

fn hull_of(own: &PointCloud, options: &HullOptions) -> (Vec<Camera>, PointCloud) {
    hull_of_object(hit_sphere, own, options)
}

fn hull_of_object(hit: Hit, own: &PointCloud, options: &HullOptions) -> (Vec<Camera>, PointCloud) {
    let cameras = cameras();
    let frames: Vec<RgbImage> = cameras.iter().map(|c| render_with(c, Some(hit))).collect();
    let wall = wall_points();
    let views: Vec<HullView> = cameras
        .iter()
        .zip(&frames)
        .map(|(camera, frame)| {
            let (median, far) = static_depths(camera, &wall).expect("the wall is in view");
            HullView {
                camera: *camera,
                frame,
                foreground: foreground(frame, &plate(camera), options).expect("sizes match"),
                median_static_depth_m: median,
                far_depth_m: far,
            }
        })
        .collect();
    let points = hull_points(&views, own, options).expect("OpenCV labels the foregrounds");
    (cameras, points)
}

#[test]
fn a_plain_sphere_without_texture_gets_points_on_its_front() {
    for model in [ForegroundModel::Difference, ForegroundModel::Soft] {
        a_plain_sphere_gets_points_on_its_front(model);
    }
}

fn a_plain_sphere_gets_points_on_its_front(model: ForegroundModel) {
    let options = HullOptions { rays_across: 80, foreground_model: model, ..HullOptions::default() };
    let (cameras, hull) = hull_of(&PointCloud::default(), &options);
    assert!(hull.len() > 200, "{} hull points", hull.len());
    // Every point is on the sphere or just in front of it (a hull is never smaller than the
    // object), none on the wall.
    let distances: Vec<f64> = hull
        .positions_world
        .iter()
        .map(|p| (DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])) - SPHERE_CENTER).length() - SPHERE_RADIUS_M)
        .collect();
    let worst = distances.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    assert!(worst < 0.25, "{model}: a hull point {worst:.3} m off the sphere");
    assert!(distances.iter().all(|d| *d > -0.02), "{model}: a point inside the sphere");
    // Seen from the middle camera, the hull's front is within 4.5% of the sphere's depth at the
    // median: cameras over 80 degrees bound the front to about r (1 / cos 40deg - 1) = 0.11 m
    // in front of the sphere (4% of its 2.65 m) at the centre, less towards the silhouette
    // (measured: 3.8%). A hull is only as tight as the cameras' spread.
    let middle = &cameras[2];
    let mut errors: Vec<f64> = hull
        .positions_world
        .iter()
        .filter_map(|p| {
            let (px, z) = middle.project_world(DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))?;
            let truth = sphere_depth(middle, px)?;
            (z <= truth * 1.2).then(|| (z - truth).abs() / truth)
        })
        .collect();
    errors.sort_by(f64::total_cmp);
    assert!(errors.len() > 50, "{model}: {} points on the middle camera's side", errors.len());
    assert!(errors[errors.len() / 2] < 0.045, "{model}: median depth error {:.2}%", 100.0 * errors[errors.len() / 2]);
}

#[test]
fn own_points_on_the_object_stand_for_the_hull() {
    let options = HullOptions { rays_across: 80, ..HullOptions::default() };
    let (_, alone) = hull_of(&PointCloud::default(), &options);
    // The sphere's surface, densely, as stereo would find it on a textured object.
    let mut own = PointCloud::default();
    for i in 0..200 {
        for j in 0..100 {
            let (theta, phi) = (std::f64::consts::TAU * i as f64 / 200.0, std::f64::consts::PI * (j as f64 + 0.5) / 100.0);
            let p = SPHERE_CENTER + SPHERE_RADIUS_M * DVec3::new(phi.sin() * theta.cos(), phi.cos(), phi.sin() * theta.sin());
            own.positions_world.push([p.x as f32, p.y as f32, p.z as f32]);
            own.colors.push([200, 30, 30]);
        }
    }
    let (_, with_own) = hull_of(&own, &options);
    assert!(with_own.len() * 10 < alone.len(), "{} of {} hull points kept beside own points", with_own.len(), alone.len());
}

#[test]
fn the_foreground_is_what_differs_from_the_plate_less_specks_and_unsure_pixels() {
    let camera = cameras()[2];
    for model in [ForegroundModel::Difference, ForegroundModel::Soft] {
        let options = HullOptions { foreground_model: model, ..HullOptions::default() };
        let background = plate(&camera);
        let same = foreground(&background.image, &background, &options).expect("sizes match");
        assert!(same.mask.data.iter().all(|v| *v == 0.0), "{model}");
        assert!(same.keeps.data.iter().all(|v| *v == 0.0), "{model}: the plate itself carves everywhere");
        let mut frame = render(&camera, true);
        frame.put_pixel(5, 5, image::Rgb([255, 255, 255]));
        let mut unsure = plate(&camera);
        unsure.confidence[(SIZE_PX.0 * 100 + 150) as usize] = 0.1;
        let fg = foreground(&frame, &unsure, &options).expect("sizes match");
        assert_eq!(fg.mask.get(5, 5), 0.0, "{model}: a single pixel is a speck");
        assert_eq!(fg.mask.get(80, 60), 1.0, "{model}: the sphere is foreground");
        assert_eq!(fg.probability.get(80, 60), 1.0, "{model}: the sphere is surely foreground");
        assert_eq!((fg.unknown.get(150, 100), fg.keeps.get(150, 100)), (1.0, 1.0), "{model}: an unsure pixel does not carve");
        assert_eq!(fg.probability.get(150, 100), 0.0, "{model}: nothing is known where the plate is unsure");
        let small = RgbImage::new(10, 10);
        assert!(foreground(&small, &background, &options).is_err());
    }
}

/// The middle camera's plate with a square (side 40 px, centred at 80, 60) of stripes 2 px wide
/// whose grey alternates `amplitude` above and below the wall's: on average the wall's colour.
fn striped_shirt(amplitude: i16) -> (Plate, RgbImage) {
    let background = plate(&cameras()[2]);
    let mut frame = background.image.clone();
    for y in 40..80 {
        for x in 60..100 {
            let sign = if (x / 2) % 2 == 0 { 1 } else { -1 };
            let p = frame.get_pixel_mut(x, y);
            p.0 = p.0.map(|v| (i16::from(v) + sign * amplitude).clamp(0, 255) as u8);
        }
    }
    (background, frame)
}

#[test]
fn a_striped_shirt_the_colour_of_the_wall_is_foreground_to_the_soft_model_and_carves_nothing() {
    // Each pixel is 0.1 from the plate: under the tolerance (0.15).
    let (background, frame) = striped_shirt(26);
    let hard_options = HullOptions { foreground_model: ForegroundModel::Difference, ..HullOptions::default() };
    let hard = foreground(&frame, &background, &hard_options).expect("sizes match");
    let soft_options = HullOptions { foreground_model: ForegroundModel::Soft, ..HullOptions::default() };
    let soft = foreground(&frame, &background, &soft_options).expect("sizes match");
    let inside = |r: &ScalarRaster| (45..75).flat_map(|y| (65..95).map(move |x| (x, y))).map(|(x, y)| r.get(x, y)).sum::<f32>() / 900.0;
    assert_eq!(inside(&hard.mask), 0.0, "the difference model sees a hole");
    assert_eq!(inside(&hard.keeps), 0.0, "and the hole carves");
    assert_eq!(inside(&soft.mask), 1.0, "the soft model sees the shirt");
    assert_eq!(inside(&soft.keeps), 1.0);
    // Not beyond it: the wall two pixels outside the shirt is no foreground.
    assert_eq!((soft.mask.get(57, 60), soft.mask.get(80, 37)), (0.0, 0.0));
}

#[test]
fn flicker_and_compression_noise_are_not_foreground_to_the_soft_model() {
    let background = plate(&cameras()[2]);
    // 4% brighter, and a deterministic noise of up to 3 code values.
    let frame = RgbImage::from_fn(SIZE_PX.0, SIZE_PX.1, |x, y| {
        let noise = ((x * 7 + y * 13) % 7) as f32 - 3.0;
        image::Rgb(background.image.get_pixel(x, y).0.map(|v| (f32::from(v) * 1.04 + noise).round().clamp(0.0, 255.0) as u8))
    });
    let options = HullOptions { foreground_model: ForegroundModel::Soft, ..HullOptions::default() };
    let fg = foreground(&frame, &background, &options).expect("sizes match");
    assert!(fg.mask.data.iter().all(|v| *v == 0.0), "foreground in flicker");
    let carving = fg.keeps.data.iter().filter(|k| **k == 0.0).count() as f64 / fg.keeps.len() as f64;
    assert!(carving > 0.99, "only {:.1}% of the pixels carve", 100.0 * carving);
}

/// A textured floor (grey and a little colour varying over a few pixels) with the square of
/// `striped_shirt` given by `inside(floor_colour)`.
fn floor_with_square(inside: impl Fn([u8; 3]) -> [u8; 3]) -> (Plate, RgbImage) {
    let floor = |x: u32, y: u32| {
        let v = 0.55 + 0.25 * (0.9 * x as f32).sin() * (0.7 * y as f32).cos();
        [(200.0 * v) as u8, (190.0 * v) as u8, (150.0 * v) as u8]
    };
    let plate_image = RgbImage::from_fn(SIZE_PX.0, SIZE_PX.1, |x, y| image::Rgb(floor(x, y)));
    let frame = RgbImage::from_fn(SIZE_PX.0, SIZE_PX.1, |x, y| {
        image::Rgb(if (60..100).contains(&x) && (40..80).contains(&y) { inside(floor(x, y)) } else { floor(x, y) })
    });
    let plate = Plate { image: plate_image, confidence: vec![1.0; (SIZE_PX.0 * SIZE_PX.1) as usize], frames: 10, others: Vec::new() };
    (plate, frame)
}

#[test]
fn a_shadow_on_a_textured_floor_is_background_with_the_shadow_cue_and_a_plain_shirt_is_not() {
    let inside = |r: &ScalarRaster| (45..75).flat_map(|y| (65..95).map(move |x| (x, y))).map(|(x, y)| r.get(x, y)).sum::<f32>() / 900.0;
    let plain = HullOptions { shadows: false, ..HullOptions::default() };
    let shadows = HullOptions { shadows: true, ..HullOptions::default() };
    // The sun blocked: every channel at 45%, the floor's texture kept.
    let (plate, shadow) = floor_with_square(|c| c.map(|v| (f32::from(v) * 0.45).round() as u8));
    assert_eq!(inside(&foreground(&shadow, &plate, &plain).expect("sizes match").mask), 1.0, "without the cue a shadow is foreground");
    let fg = foreground(&shadow, &plate, &shadows).expect("sizes match");
    assert_eq!(inside(&fg.mask), 0.0, "with it the shadow is the floor");
    assert_eq!(inside(&fg.keeps), 0.0, "and carves");
    // A plain shirt of the floor's mean colour darkened alike: the texture is gone.
    let (plate, shirt) = floor_with_square(|_| [50, 47, 37]);
    assert_eq!(inside(&foreground(&shirt, &plate, &shadows).expect("sizes match").mask), 1.0, "a plain shirt stays foreground");
    // Dark trousers that keep the floor's texture by chance are darker than any shadow.
    let (plate, dark) = floor_with_square(|c| c.map(|v| (f32::from(v) * 0.2).round() as u8));
    assert_eq!(inside(&foreground(&dark, &plate, &shadows).expect("sizes match").mask), 1.0, "darker than a shadow stays foreground");
}

#[test]
fn the_shadow_cue_wants_one_gain_in_every_channel_and_the_texture_kept() {
    use super::foreground::shadow_cue;
    let plate = [0.6, 0.5, 0.4];
    assert_eq!(shadow_cue([0.3, 0.25, 0.2], plate, 0.95), 1.0);
    assert_eq!(shadow_cue([0.3, 0.25, 0.2], plate, 0.2), 0.0, "texture lost");
    assert_eq!(shadow_cue([0.2, 0.25, 0.3], plate, 0.95), 0.0, "another hue");
    assert_eq!(shadow_cue([0.1, 0.083, 0.067], plate, 0.95), 0.0, "too dark for a shadow");
    assert_eq!(shadow_cue(plate, plate, 1.0), 0.0, "no darker");
    assert_eq!(shadow_cue([0.3, 0.25, 0.2], [0.03, 0.02, 0.01], 0.95), 0.0, "a plate too dark to tell");
}

#[test]
fn foreground_models_are_named() {
    assert_eq!("soft".parse::<ForegroundModel>(), Ok(ForegroundModel::Soft));
    assert_eq!("difference".parse::<ForegroundModel>(), Ok(ForegroundModel::Difference));
    assert_eq!(ForegroundModel::Soft.to_string(), "soft");
    assert!("otsu".parse::<ForegroundModel>().unwrap_err().contains("difference or soft"));
}

#[test]
fn options_out_of_range_are_named() {
    for bad in [
        HullOptions { foreground_tolerance: 0.0, ..HullOptions::default() },
        HullOptions { min_witnesses: 0, ..HullOptions::default() },
        HullOptions { min_region_rays: 1_000_000, ..HullOptions::default() },
        HullOptions { depth_samples: 1, ..HullOptions::default() },
        HullOptions { near_fraction: f64::NAN, ..HullOptions::default() },
    ] {
        assert!(bad.validate().is_err(), "{bad:?}");
    }
    HullOptions::default().validate().expect("defaults are valid");
}

#[test]
fn a_small_foreground_region_is_sampled_more_finely_than_a_large_one() {
    // A 40x40 region and a 6x6 one, apart, on a 64x64 mask.
    let mut mask = ScalarRaster::filled(64, 64, 0.0);
    for y in 0..64 {
        for x in 0..64 {
            if (x < 40 && y < 40) || ((50..56).contains(&x) && (50..56).contains(&y)) {
                mask.data[y * 64 + x] = 1.0;
            }
        }
    }
    let strides = region_strides(&mask, 4, 16).unwrap();
    // The large region has 100 rays on the grid of 4 px: enough. The small one would have 2 or
    // 3 there; on the grid of 1 px it has 36, at least the 16 asked.
    assert_eq!(strides[10 * 64 + 10], 4);
    assert_eq!(strides[52 * 64 + 52], 1);
    assert_eq!(strides[45 * 64 + 45], 0, "off the foreground");
    // A region of 200 px (10x20) wants 16 rays: every 3rd pixel (200 / 16 = 12.5 px a ray).
    let mut medium = ScalarRaster::filled(64, 64, 0.0);
    (0..20).for_each(|y| (0..10).for_each(|x| medium.data[y * 64 + x] = 1.0));
    assert_eq!(region_strides(&medium, 4, 16).unwrap()[0], 3);
    // Without a minimum every region is on the base grid.
    assert!(region_strides(&mask, 4, 0).unwrap().iter().all(|&s| s == 0 || s == 4));
}

#[test]
fn own_points_on_a_plain_faces_edges_move_the_hull_onto_the_face() {
    // Stereo finds a plain cube's vertical edges (shading changes there) and nothing between:
    // points down the front face's two sides, just inside them.
    let front_z = SPHERE_CENTER.z - CUBE_HALF_M;
    let mut edges = PointCloud::default();
    for side in [-1.0, 1.0] {
        for j in 0..30 {
            let p = DVec3::new(SPHERE_CENTER.x + side * 0.97 * CUBE_HALF_M, SPHERE_CENTER.y - CUBE_HALF_M + 0.02 * j as f64, front_z);
            edges.positions_world.push([p.x as f32, p.y as f32, p.z as f32]);
            edges.colors.push([200, 30, 30]);
        }
    }
    // The median depth error of the hull points on the face's middle half, seen by the middle
    // camera (the face is 2.7 m from it).
    let middle = cameras()[2];
    let face_error = |options: &HullOptions| {
        let (_, hull) = hull_of_object(hit_cube, &edges, options);
        let mut errors: Vec<f64> = hull
            .positions_world
            .iter()
            .map(|p| DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
            .filter(|p| (p.x - SPHERE_CENTER.x).abs() < 0.5 * CUBE_HALF_M && (p.y - SPHERE_CENTER.y).abs() < 0.5 * CUBE_HALF_M)
            .filter_map(|p| middle.project_world(p))
            .map(|(px, z)| {
                let eye = middle.center_world();
                let dir = (middle.unproject_world(px, 1.0) - eye).normalize();
                let truth = middle.project_world(eye + hit_cube(eye, dir).expect("on the cube") * dir).expect("in front").1;
                (z - truth).abs() / truth
            })
            .collect();
        assert!(errors.len() > 10, "{} hull points on the face's middle", errors.len());
        errors.sort_by(f64::total_cmp);
        errors[errors.len() / 2]
    };
    // Cameras over 80 degrees carve a hull that reaches up to r (cot 40deg + 1) - r = 0.36 m in
    // front of the face's middle (r its half side, seen from afar; measured: 8.1% of its depth
    // at the median over the face's middle half); the edges put it on the face (0.3%).
    let options = HullOptions { rays_across: 40, own_point_reach: 0, ..HullOptions::default() };
    let loose = face_error(&options);
    let onto = face_error(&HullOptions { own_point_reach: 6, ..options });
    assert!(loose > 0.04, "the hull alone is {:.2}% off the face", 100.0 * loose);
    assert!(onto < 0.01, "with the edges {:.2}% off the face (alone {:.2}%)", 100.0 * onto, 100.0 * loose);
}
