use super::*;
use dynview_core::rotation::matrix_from_angle_axis;

fn known_similarity() -> Similarity3 {
    Similarity3 { scale: 2.5, rotation: matrix_from_angle_axis(DVec3::new(0.3, -1.1, 0.7)), translation: DVec3::new(4.0, -2.0, 0.5) }
}

fn max_abs_diff(a: DMat3, b: DMat3) -> f64 {
    (a - b).to_cols_array().iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// Cameras on a rough ring looking at the origin, named `cam/NN.png`.
fn ring_poses(count: usize) -> BTreeMap<String, Rigid3> {
    (0..count)
        .map(|i| {
            let angle = i as f64 * std::f64::consts::TAU / count as f64;
            let eye = DVec3::new(3.0 * angle.cos(), 0.4 * (3.0 * angle).sin(), 3.0 * angle.sin());
            (format!("cam/{i:02}.png"), Rigid3::camera_from_world_looking_at(eye, DVec3::ZERO, DVec3::Y))
        })
        .collect()
}

#[test]
fn recovers_a_known_similarity_exactly() {
    let sim = known_similarity();
    let source: Vec<DVec3> = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0], [1.5, -0.5, 2.0]]
        .iter()
        .map(|p| DVec3::from_array(*p))
        .collect();
    let target: Vec<DVec3> = source.iter().map(|p| sim.transform_point(*p)).collect();
    let fit = similarity_from_point_pairs(&source, &target).unwrap();
    assert!((fit.scale - sim.scale).abs() < 1e-12, "{fit:?}");
    assert!(max_abs_diff(fit.rotation, sim.rotation) < 1e-12, "{fit:?}");
    assert!((fit.translation - sim.translation).length() < 1e-11, "{fit:?}");
    assert!((fit.rotation.determinant() - 1.0).abs() < 1e-12);
}

#[test]
fn recovers_a_half_turn_and_planar_points() {
    // A rotation by pi (the hardest case for quaternion sign conventions) on coplanar points.
    let sim =
        Similarity3 { scale: 0.1, rotation: matrix_from_angle_axis(DVec3::new(0.0, std::f64::consts::PI, 0.0)), translation: DVec3::X };
    let source: Vec<DVec3> = (0..6).map(|i| DVec3::new(f64::from(i).cos(), f64::from(i).sin(), 0.0)).collect();
    let target: Vec<DVec3> = source.iter().map(|p| sim.transform_point(*p)).collect();
    let fit = similarity_from_point_pairs(&source, &target).unwrap();
    assert!(max_abs_diff(fit.rotation, sim.rotation) < 1e-12, "{fit:?}");
    assert!((fit.scale - 0.1).abs() < 1e-14);
}

#[test]
fn least_squares_with_noise_beats_the_noise() {
    let sim = known_similarity();
    let source: Vec<DVec3> = (0..40).map(|i| DVec3::new(f64::from(i % 7), f64::from(i % 5), f64::from(i % 3)) * 0.3).collect();
    // Deterministic zero-mean "noise".
    let target: Vec<DVec3> = source
        .iter()
        .enumerate()
        .map(|(i, p)| sim.transform_point(*p) + 1e-3 * DVec3::new((i as f64 * 1.7).sin(), (i as f64 * 2.3).cos(), (i as f64 * 0.9).sin()))
        .collect();
    let fit = similarity_from_point_pairs(&source, &target).unwrap();
    assert!((fit.scale - sim.scale).abs() < 1e-3);
    assert!(max_abs_diff(fit.rotation, sim.rotation) < 1e-3);
}

#[test]
fn degenerate_inputs_are_errors() {
    let line: Vec<DVec3> = (0..5).map(|i| DVec3::splat(f64::from(i))).collect();
    assert!(matches!(similarity_from_point_pairs(&line, &line), Err(AlignError::Degenerate)));
    let two = [DVec3::ZERO, DVec3::X];
    assert!(matches!(similarity_from_point_pairs(&two, &two), Err(AlignError::TooFewPoints { found: 2 })));
    assert!(matches!(similarity_from_point_pairs(&two, &two[..1]), Err(AlignError::LengthMismatch { .. })));
    let bad = [DVec3::ZERO, DVec3::X, DVec3::new(f64::NAN, 0.0, 0.0)];
    assert!(matches!(similarity_from_point_pairs(&bad, &bad), Err(AlignError::NonFinite { index: 2 })));
    // A mirrored target still gives a proper rotation, never a reflection.
    let source = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
    let mirrored: Vec<DVec3> = source.iter().map(|p| DVec3::new(-p.x, p.y, p.z)).collect();
    if let Ok(fit) = similarity_from_point_pairs(&source, &mirrored) {
        assert!((fit.rotation.determinant() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn inverse_and_camera_mapping_agree() {
    let sim = known_similarity();
    let p = DVec3::new(0.2, -0.7, 1.9);
    assert!((sim.inverse().transform_point(sim.transform_point(p)) - p).length() < 1e-12);
    // A camera mapped into the other world sees the mapped point in the same direction.
    let camera_from_a = Rigid3::camera_from_world_looking_at(DVec3::new(1.0, 2.0, -3.0), DVec3::ZERO, DVec3::Y);
    let camera_from_b = sim.transform_camera_from_world(&camera_from_a);
    let seen_a = camera_from_a.transform_point(p);
    let seen_b = camera_from_b.transform_point(sim.transform_point(p));
    assert!((seen_b - sim.scale * seen_a).length() < 1e-12, "{seen_a} {seen_b}");
}

#[test]
fn transformed_copy_has_zero_error() {
    let truth = ring_poses(12);
    let true_from_estimated = known_similarity();
    let estimated_from_true = true_from_estimated.inverse();
    let estimated: BTreeMap<String, Rigid3> =
        truth.iter().map(|(name, pose)| (name.clone(), estimated_from_true.transform_camera_from_world(pose))).collect();
    for (robust, centers_only) in [(false, false), (true, false), (false, true), (true, true)] {
        let report = evaluate_poses(&estimated, &truth, PoseEvalOptions { robust, centers_only }).unwrap();
        assert_eq!((report.registered, report.ground_truth_images, report.missing.len()), (12, 12, 0));
        assert!(report.rotation_error_max_deg < 1e-9, "{report:?}");
        assert!(report.center_error_max_fraction < 1e-12, "{report:?}");
        assert!((report.true_from_estimated.scale - true_from_estimated.scale).abs() < 1e-12);
        assert!(max_abs_diff(report.true_from_estimated.rotation, true_from_estimated.rotation) < 1e-12);
    }
}

#[test]
fn known_perturbation_gives_known_error() {
    let truth = ring_poses(10);
    let true_from_estimated = known_similarity();
    let estimated_from_true = true_from_estimated.inverse();
    let mut estimated: BTreeMap<String, Rigid3> =
        truth.iter().map(|(name, pose)| (name.clone(), estimated_from_true.transform_camera_from_world(pose))).collect();
    // Turn one estimated camera by 2 degrees about its own optical axis (centre unchanged).
    let turned = "cam/03.png";
    let pose = estimated[turned];
    let center = pose.camera_center_world();
    let rotation = matrix_from_angle_axis(DVec3::Z * 2f64.to_radians()) * pose.rotation;
    estimated.insert(turned.into(), Rigid3::new(rotation, -(rotation * center)));
    // Drop one image: it is reported missing, not compared.
    estimated.remove("cam/07.png");
    // Centres alone fix the similarity, so the turned camera carries its whole error.
    let centers_only = PoseEvalOptions { centers_only: true, ..PoseEvalOptions::default() };
    let report = evaluate_poses(&estimated, &truth, centers_only).unwrap();
    assert_eq!((report.registered, report.missing.clone()), (9, vec!["cam/07.png".to_string()]));
    let turned_error = report.per_image.iter().find(|e| e.name == turned).unwrap();
    assert!((turned_error.rotation_error_deg - 2.0).abs() < 1e-9, "{turned_error:?}");
    assert!((report.rotation_error_max_deg - 2.0).abs() < 1e-9);
    assert!(report.rotation_error_median_deg < 1e-9);
    assert!(report.center_error_max_fraction < 1e-12);
    // Fitted to the orientations, the 2 degrees are shared: 1/9 of them moves the mean.
    let report = evaluate_poses(&estimated, &truth, PoseEvalOptions::default()).unwrap();
    let turned_error = report.per_image.iter().find(|e| e.name == turned).unwrap();
    assert!((turned_error.rotation_error_deg - 2.0 * 8.0 / 9.0).abs() < 1e-3, "{turned_error:?}");
    assert!((report.rotation_error_median_deg - 2.0 / 9.0).abs() < 1e-3, "{report:?}");
}

#[test]
fn orientations_fix_the_rotation_of_cameras_on_a_line() {
    // Centres on a line (plus noise) leave the rotation about the line free for Umeyama; the
    // orientations do not.
    let truth: BTreeMap<String, Rigid3> = (0..8)
        .map(|i| {
            let eye = DVec3::new(i as f64, 0.01 * ((i * 7 % 5) as f64 - 2.0), 0.0);
            (format!("{i}"), Rigid3::camera_from_world_looking_at(eye, eye + DVec3::new(0.0, 0.2, 5.0), DVec3::Y))
        })
        .collect();
    let estimated_from_true = known_similarity().inverse();
    let mut estimated: BTreeMap<String, Rigid3> =
        truth.iter().map(|(name, pose)| (name.clone(), estimated_from_true.transform_camera_from_world(pose))).collect();
    // Nudge every estimated centre by 1 mm: the centres-only rotation about the line swings.
    for (i, pose) in estimated.values_mut().enumerate() {
        let c = pose.camera_center_world() + DVec3::new(0.0, if i % 2 == 0 { 0.001 } else { -0.001 }, 0.0);
        *pose = Rigid3::new(pose.rotation, -(pose.rotation * c));
    }
    let by_orientation = evaluate_poses(&estimated, &truth, PoseEvalOptions::default()).unwrap();
    let by_centres = evaluate_poses(&estimated, &truth, PoseEvalOptions { centers_only: true, ..PoseEvalOptions::default() }).unwrap();
    assert!(by_orientation.rotation_error_max_deg < 1e-9, "{by_orientation:?}");
    assert!(by_centres.rotation_error_median_deg > 0.1, "{by_centres:?}");
}

#[test]
fn known_centre_offset_is_a_fraction_of_the_scene_size() {
    // Six cameras; the true centres span a 4 x 3 x 0 box (diagonal 5). Robust fitting drops the
    // moved camera, so its whole offset shows as error and the others stay exact.
    let eyes = [[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [4.0, 3.0, 0.0], [0.0, 3.0, 0.0], [2.0, 1.0, 0.0], [1.0, 2.0, 0.0]];
    let truth: BTreeMap<String, Rigid3> = eyes
        .iter()
        .enumerate()
        .map(|(i, e)| (format!("{i}"), Rigid3::camera_from_world_looking_at(DVec3::from_array(*e), DVec3::new(2.0, 1.5, 5.0), DVec3::Y)))
        .collect();
    let mut estimated = truth.clone();
    let pose = truth["4"];
    let offset = DVec3::new(0.0, 0.0, 0.5);
    estimated.insert("4".into(), Rigid3::new(pose.rotation, -(pose.rotation * (pose.camera_center_world() + offset))));
    let report = evaluate_poses(&estimated, &truth, PoseEvalOptions { robust: true, ..PoseEvalOptions::default() }).unwrap();
    assert!((report.scene_size - 5.0).abs() < 1e-12);
    assert_eq!(report.fitted_on, 5);
    let moved = report.per_image.iter().find(|e| e.name == "4").unwrap();
    assert!((moved.center_error_fraction - 0.1).abs() < 1e-9, "{moved:?}");
    assert!(report.center_error_median_fraction < 1e-9);
    assert!(report.rotation_error_max_deg < 1e-9);
    // Least squares over all of them spreads the offset instead.
    let plain = evaluate_poses(&estimated, &truth, PoseEvalOptions::default()).unwrap();
    assert!(plain.center_error_max_fraction < 0.1 && plain.center_error_median_fraction > 1e-6);
}

#[test]
fn coincident_truth_is_an_error() {
    let pose = Rigid3::IDENTITY;
    let truth: BTreeMap<String, Rigid3> = (0..4).map(|i| (format!("{i}"), pose)).collect();
    assert!(matches!(evaluate_poses(&truth, &truth, PoseEvalOptions::default()), Err(AlignError::ZeroSceneSize)));
}

#[test]
fn view_rotation_is_identity_for_the_same_intrinsics_and_for_a_focal_change() {
    // The principal point in the middle of the 640 x 360 grid of pixel centres.
    let reference = Intrinsics { fx: 600.0, fy: 600.0, cx: 319.5, cy: 179.5 };
    assert!(max_abs_diff(view_rotation(&reference, &reference, 640, 360), DMat3::IDENTITY) < 1e-12);
    let longer = Intrinsics { fx: 612.0, fy: 612.0, ..reference };
    let angle = angle_axis_from_matrix(view_rotation(&reference, &longer, 640, 360)).length();
    assert!(angle < 1e-9, "a focal change alone turns the view by {angle} rad");
}

#[test]
fn a_principal_point_off_turns_into_the_rotation_that_sees_the_same_world() {
    // The estimated camera's principal point is 6 px left and 4 px below the reference's; turned
    // by the view rotation's inverse, it projects the world about where the reference camera does.
    let reference = Intrinsics { fx: 700.0, fy: 700.0, cx: 320.0, cy: 180.0 };
    let estimated = Intrinsics { cx: 314.0, cy: 184.0, ..reference };
    let q = view_rotation(&reference, &estimated, 640, 360);
    let expected = (6.0_f64.hypot(4.0) / 700.0).atan();
    let angle = angle_axis_from_matrix(q).length();
    assert!((angle - expected).abs() < 0.1 * expected, "{angle} rad against {expected}");
    let truth = Rigid3::camera_from_world_looking_at(DVec3::new(0.0, 1.0, -5.0), DVec3::ZERO, DVec3::Y);
    let turned = Rigid3::new(q.transpose() * truth.rotation, q.transpose() * truth.translation);
    let mut worst_px: f64 = 0.0;
    for (x, y) in [(-1.5, -0.8), (0.0, 0.0), (1.4, 0.9), (-1.2, 1.0), (1.3, -1.1)] {
        let point = DVec3::new(x, y, 0.3 * x);
        let want = reference.project(truth.transform_point(point)).unwrap();
        let got = estimated.project(turned.transform_point(point)).unwrap();
        worst_px = worst_px.max((want - got).length());
    }
    let untouched =
        estimated.project(truth.transform_point(DVec3::ZERO)).unwrap() - reference.project(truth.transform_point(DVec3::ZERO)).unwrap();
    // Turned, it lands within a tenth of the untouched camera's 7.2 px (what remains is the
    // difference between a shifted image and a turned one away from the centre).
    assert!(
        worst_px < 0.1 * untouched.length() && untouched.length() > 7.0,
        "turned: {worst_px} px off; not turned: {} px",
        untouched.length()
    );
}
