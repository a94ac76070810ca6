//! The text of `real.md`: its header, what is measured, and one section per capture with the
//! scores of every method (the mean over the held-out cameras, then each camera), the prep
//! figures, the strips and the command that reproduces them.

use std::fmt::Write as _;

use dynview_core::render::RenderParams;

use super::orbit::{OFF_ARC_DEG, VIEWS as ORBIT_VIEWS};
use super::run::{CameraResult, Options, orbit_strip_name, strip_name, work_folder};
use super::scores::{MOVING_DILATION_PX, MOVING_THRESHOLD, RawAndCorrected, Score};
use crate::datasets::real_captures::RealCapture;

/// The report's opening paragraphs (after its title).
pub(super) fn header() -> String {
    format!(
        "For each camera left out, `dynview prep` runs on the others with their calibrated poses, and the \
     left-out camera is rendered at each time step from that package and compared with its real frame. Its intrinsics, pose and \
     reference frames come from a package prepared the same way from all cameras (same undistortion and size), as filmed: the \
     package's color balance reaches only the renderer's inputs. Every capture is evaluated on all its frames, every interior \
     camera left out in turn and, on the Panoptic arcs, also the highest and the lowest camera (views off the others' arc, \
     averaged apart), unless the reproduce line says otherwise.\n\n\
     Measures, averaged over the time steps: PSNR and SSIM on the whole frame, raw and colour-corrected (cc: per frame and per \
     channel, the affine map `a * render + b` that best fits the real frame by least squares is applied to the render first, \
     clamped to [0, 1], so that a camera whose response differs from its neighbours' does not decide the score; gsplat's \
     `cc_psnr` fits a richer map); PSNR and SSIM over the static and over the moving pixels, raw / cc (a pixel of a frame moves where the \
     real frame differs from the held-out camera's temporal median over the frames used by more than {MOVING_THRESHOLD} in some channel, \
     dilated by {MOVING_DILATION_PX} pixels; PSNR from the mean squared error over the region's pixels, SSIM the mean of the frame's SSIM \
     map over them, each averaged over the frames where the region has pixels); flicker, the mean frame-to-frame change of the output where the real frame does not change, minus the real \
     frame's own (x1000, lower is steadier). The floor is the nearest input camera's frame shown as is, as filmed (ranked as the \
     renderer ranks views): a rendering worse than it is worse than showing no synthesis at all. The plane view is an \
     experiment: that same input warped with one plane fitted to the sparse depth and nothing else (the full method pulls its \
     depth toward such a plane only where points are scarce, `lambda_plane`). What the figures show, and what was tried: \
     [real_findings.md](real_findings.md).\n\n"
    )
}

/// The columns of the score tables after the row's names.
const SCORE_COLUMNS: &str = "PSNR (dB) | SSIM | cc PSNR (dB) | cc SSIM | static PSNR (dB), raw / cc | moving PSNR (dB), raw / cc | \
     static SSIM, raw / cc | moving SSIM, raw / cc | flicker";
/// How many columns [`SCORE_COLUMNS`] names.
const SCORE_COLUMN_COUNT: usize = 9;

/// The section of `capture`: `results` of its held-out cameras on the first `frames` frames,
/// prepared at `size_px` (width, height); the reference package took `reference_secs` of prep.
/// The means are taken over the `interior` cameras and over the others (off the arc) apart.
pub(super) fn markdown(
    capture: RealCapture,
    results: &[CameraResult],
    interior: &[String],
    options: &Options,
    frames: u32,
    size_px: (u32, u32),
    reference_secs: f64,
) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "## {}\n", capture.label());
    let _ = writeln!(
        s,
        "{} First {frames} of its {} frames, prepared at {}x{} (`--working-width {}`); the reference package of all cameras took \
         {reference_secs:.0} s of prep.\n",
        capture.description(),
        capture.frame_count(),
        size_px.0,
        size_px.1,
        capture.working_width_px()
    );
    let (inside, outside): (Vec<&CameraResult>, Vec<&CameraResult>) = results.iter().partition(|r| interior.contains(&r.name));
    let groups: Vec<(&str, Vec<&CameraResult>)> = if inside.is_empty() || outside.is_empty() {
        vec![("held-out cameras", results.iter().collect())]
    } else {
        vec![
            ("interior cameras", inside),
            ("cameras off the arc (the highest and the lowest seen from the point the cameras look at, where not interior)", outside),
        ]
    };
    for (what, group) in groups {
        let _ = writeln!(s, "Mean over the {what}: {}\n", group.iter().map(|r| r.name.as_str()).collect::<Vec<_>>().join(", "));
        mean_table(&mut s, &group);
        s.push('\n');
    }
    let _ = writeln!(
        s,
        "Per held-out camera:\n\n| held-out camera | method | {SCORE_COLUMNS} |\n| --- | --- |{}",
        " ---: |".repeat(SCORE_COLUMN_COUNT)
    );
    for r in results {
        for score in &r.scores {
            let _ = writeln!(s, "| {} | {} | {} |", r.name, score.label, cells(score));
        }
    }
    let _ = writeln!(
        s,
        "\n| held-out camera | nearest input | moving pixels (%) | points per step | depth error, full / blend (median %) | last prep run (s) | full ms/frame (CPU) |"
    );
    let _ = writeln!(s, "| --- | --- | ---: | ---: | ---: | ---: | ---: |");
    for r in results {
        let _ = writeln!(
            s,
            "| {} | {} | {:.1} | {:.0} | {:.1} / {:.1} | {:.0} | {:.0} |",
            r.name, r.nearest, r.moving_pct, r.points_per_step, r.depth_error_pct[0], r.depth_error_pct[1], r.prep_secs, r.ms_per_frame
        );
    }
    let _ = writeln!(
        s,
        "\nPoints per step include the static points lent to the step. The depth error compares the rendered depth with what the \
         held-out camera's own frame implies: the points of the reference package (prepared with it) that it sees, z-buffered and \
         filtered as the renderer filters points, at every time step. The blend's depth is the push-pull filled sparse depth. The last prep run is the one that wrote the package; one \
         that reused the prepared steps of an earlier run counts only what it redid (`--fresh` times whole runs).\n\n\
         Strips (middle time step): real frame | nearest input as is | blend | full | depth of full | the nearest input's background plate (as the renderer reads it: colour-balanced; black without one).\n"
    );
    for r in results {
        let _ = writeln!(s, "![{}]({})", r.name, strip_name(capture, &r.name));
    }
    if capture.panoptic_arc().is_some() {
        let _ = writeln!(
            s,
            "\nViews away from the arc (the package of all cameras, middle time step; {} views looking at the point the cameras \
             look at, from the second camera's azimuth to the second to last's): the full method along the arc (top), {OFF_ARC_DEG:.0} \
             degrees above it (middle) and the blend there (bottom). Each moving object should be shown once.\n\n![orbit]({})",
            ORBIT_VIEWS,
            orbit_strip_name(capture)
        );
    }
    let _ = writeln!(
        s,
        "\nReproduce: `cargo xtask eval --real --capture {} --frames {frames}{}{}{}` (work in `{}/{}/`; `--fresh` redoes the prep runs).\n",
        capture.label(),
        options.held_out.iter().filter(|c| results.iter().any(|r| &r.name == *c)).map(|c| format!(" --held-out {c}")).collect::<String>(),
        options.prep_args.iter().map(|a| format!(" --prep-arg={a}")).collect::<String>(),
        changed_params(options.params.as_ref()).map(|json| format!(" --params '{json}'")).unwrap_or_default(),
        work_folder(&options.prep_args),
        capture.label()
    );
    s
}

/// The table of each method's mean score over `results`.
fn mean_table(s: &mut String, results: &[&CameraResult]) {
    let methods = results.first().map_or(0, |r| r.scores.len());
    let _ = writeln!(s, "| method | {SCORE_COLUMNS} |\n| --- |{}", " ---: |".repeat(SCORE_COLUMN_COUNT));
    for i in 0..methods {
        let scores: Vec<&Score> = results.iter().map(|r| &r.scores[i]).collect();
        let _ = writeln!(s, "| {} | {} |", scores[0].label, cells(&mean_score(&scores)));
    }
}

/// The score columns of one row ([`SCORE_COLUMNS`]).
fn cells(x: &Score) -> String {
    let pair = |p: RawAndCorrected| format!("{} / {}", number(p.raw, 2), number(p.corrected, 2));
    let pair4 = |p: RawAndCorrected| format!("{} / {}", number(p.raw, 4), number(p.corrected, 4));
    [
        number(x.psnr_db.raw, 2),
        number(x.ssim.raw, 4),
        number(x.psnr_db.corrected, 2),
        number(x.ssim.corrected, 4),
        pair(x.static_psnr_db),
        pair(x.moving_psnr_db),
        pair4(x.static_ssim),
        pair4(x.moving_ssim),
        number(x.flicker * 1000.0, 2),
    ]
    .join(" | ")
}

/// `value` with `decimals` decimals, a dash when it is not a number.
fn number(value: f64, decimals: usize) -> String {
    if value.is_nan() { "–".to_string() } else { format!("{value:.decimals$}") }
}

/// The mean of `scores` (one method's on several cameras), measure by measure, over the cameras
/// where the measure has a value.
fn mean_score(scores: &[&Score]) -> Score {
    let mean = |f: &dyn Fn(&Score) -> f64| {
        let values: Vec<f64> = scores.iter().map(|s| f(s)).filter(|v| !v.is_nan()).collect();
        if values.is_empty() { f64::NAN } else { values.iter().sum::<f64>() / values.len() as f64 }
    };
    let pair = |f: &dyn Fn(&Score) -> RawAndCorrected| RawAndCorrected { raw: mean(&|s| f(s).raw), corrected: mean(&|s| f(s).corrected) };
    Score {
        label: scores.first().map_or("", |s| s.label),
        psnr_db: pair(&|s| s.psnr_db),
        ssim: pair(&|s| s.ssim),
        static_psnr_db: pair(&|s| s.static_psnr_db),
        moving_psnr_db: pair(&|s| s.moving_psnr_db),
        static_ssim: pair(&|s| s.static_ssim),
        moving_ssim: pair(&|s| s.moving_ssim),
        flicker: mean(&|s| s.flicker),
    }
}

/// The renderer parameters that differ from the defaults, as JSON; `None` when none do.
pub(super) fn changed_params(params: Option<&RenderParams>) -> Option<String> {
    let params = serde_json::to_value(params?).ok()?;
    let defaults = serde_json::to_value(RenderParams::default()).ok()?;
    let (serde_json::Value::Object(params), serde_json::Value::Object(defaults)) = (params, defaults) else { return None };
    let changed: serde_json::Map<String, serde_json::Value> = params.into_iter().filter(|(k, v)| defaults.get(k) != Some(v)).collect();
    (!changed.is_empty()).then(|| serde_json::Value::Object(changed).to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn score(label: &'static str, psnr_db: f64, moving_psnr_db: f64) -> Score {
        let pair = |v: f64| RawAndCorrected { raw: v, corrected: v + 1.0 };
        Score {
            label,
            psnr_db: pair(psnr_db),
            ssim: RawAndCorrected { raw: 0.5, corrected: 0.6 },
            static_psnr_db: pair(psnr_db + 2.0),
            moving_psnr_db: pair(moving_psnr_db),
            static_ssim: RawAndCorrected { raw: 0.7, corrected: 0.75 },
            moving_ssim: if moving_psnr_db.is_nan() { pair(f64::NAN) } else { RawAndCorrected { raw: 0.4, corrected: 0.45 } },
            flicker: 0.01,
        }
    }

    fn result(name: &str, scores: Vec<Score>) -> CameraResult {
        CameraResult {
            name: name.to_string(),
            scores,
            nearest: "cam02".to_string(),
            prep_secs: 10.0,
            ms_per_frame: 100.0,
            points_per_step: 1000.0,
            depth_error_pct: [0.3, 0.4],
            moving_pct: 12.5,
        }
    }

    #[test]
    fn the_column_count_matches_the_columns_named() {
        assert_eq!(SCORE_COLUMNS.matches('|').count() + 1, SCORE_COLUMN_COUNT);
        assert_eq!(cells(&score("x", 20.0, 15.0)).matches('|').count() + 1, SCORE_COLUMN_COUNT);
    }

    #[test]
    fn changed_parameters_are_the_ones_off_their_defaults() {
        assert_eq!(changed_params(Some(&RenderParams::default())), None);
        let params = RenderParams { lambda_plane: 0.0, ..RenderParams::default() };
        assert_eq!(changed_params(Some(&params)).as_deref(), Some(r#"{"lambda_plane":0.0}"#));
    }

    #[test]
    fn the_section_has_the_means_every_camera_and_the_reproduce_line() {
        use clap::Parser;
        #[derive(Parser)]
        struct Cli {
            #[command(flatten)]
            options: Options,
        }
        let options = Cli::parse_from(["x", "--capture", "panoptic-arc2", "--held-out", "cam09", "--held-out", "cam04"]).options;
        assert_eq!(options.capture, [RealCapture::PanopticArc2]);
        assert_eq!(options.frames, None);
        let results = [
            result("cam09", vec![score("full", 20.0, 15.0), score("blend", 18.0, f64::NAN)]),
            result("cam04", vec![score("full", 22.0, f64::NAN), score("blend", 16.0, f64::NAN)]),
        ];
        let interior = ["cam09".to_string(), "cam04".to_string(), "cam07".to_string()];
        let text = markdown(RealCapture::PanopticArc2, &results, &interior, &options, 75, (640, 360), 20.0);
        assert!(text.starts_with("## panoptic-arc2\n"), "{text}");
        assert!(text.contains("First 75 of its 75 frames, prepared at 640x360"), "{text}");
        // The mean skips the camera without moving pixels; a measure without any value is a dash.
        assert!(
            text.contains(
                "| full | 21.00 | 0.5000 | 22.00 | 0.6000 | 23.00 / 24.00 | 15.00 / 16.00 | 0.7000 / 0.7500 | 0.4000 / 0.4500 | 10.00 |"
            ),
            "{text}"
        );
        assert!(
            text.contains("| blend | 17.00 | 0.5000 | 18.00 | 0.6000 | 19.00 / 20.00 | – / – | 0.7000 / 0.7500 | – / – | 10.00 |"),
            "{text}"
        );
        assert!(text.contains("| cam04 | blend | 16.00 |"), "{text}");
        assert!(text.contains("| cam09 | cam02 | 12.5 | 1000 | 0.3 / 0.4 | 10 | 100 |"), "{text}");
        assert!(text.contains("![cam04](real_strip_panoptic-arc2_cam04.png)"), "{text}");
        assert!(text.contains("`cargo xtask eval --real --capture panoptic-arc2 --frames 75 --held-out cam09 --held-out cam04`"), "{text}");
        assert!(text.contains("Mean over the held-out cameras: cam09, cam04\n"), "{text}");
        assert!(text.contains("![orbit](orbit_strip_panoptic-arc2.png)"), "{text}");
    }

    #[test]
    fn cameras_off_the_arc_are_averaged_apart_from_the_interior_ones() {
        use clap::Parser;
        #[derive(Parser)]
        struct Cli {
            #[command(flatten)]
            options: Options,
        }
        let options = Cli::parse_from(["x", "--capture", "panoptic-arc2"]).options;
        let results = [
            result("cam09", vec![score("full", 20.0, 15.0)]),
            result("cam04", vec![score("full", 22.0, 17.0)]),
            result("cam02", vec![score("full", 10.0, 5.0)]),
        ];
        let interior = ["cam09".to_string(), "cam04".to_string(), "cam07".to_string()];
        let text = markdown(RealCapture::PanopticArc2, &results, &interior, &options, 75, (640, 360), 20.0);
        let inside = text.find("Mean over the interior cameras: cam09, cam04\n").expect("interior mean");
        let outside = text.find("Mean over the cameras off the arc").expect("off-arc mean");
        assert!(inside < outside, "{text}");
        assert!(text[inside..outside].contains("| full | 21.00 |"), "{text}");
        assert!(text[outside..].contains("where not interior): cam02\n\n| method |"), "{text}");
        assert!(text[outside..].contains("| full | 10.00 |"), "{text}");
    }
}
