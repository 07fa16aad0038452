//! Stereo calibration on OpenCV's 13 real chessboard pairs (tests/data/opencv_stereo_calib_9x6).

use std::path::{Path, PathBuf};

use kestrel_proto::Time;
use kestrel_vision::image::{gray_bytes, load_gray};
use kestrel_vision::{
    Geometry, PipelineParams, StereoCalibration, StereoFrame, StereoGeometry, StereoPipeline, VisionError,
    calibrate, depth_scale_from_references,
};

fn data(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/opencv_stereo_calib_9x6")
        .join(name)
        .display()
        .to_string()
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("vision-calibration");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn thirteen_real_pairs_calibrate_below_half_a_pixel_and_round_trip_through_the_yaml() {
    let out = scratch("stereo.yaml");
    let report = calibrate(&data("left*.jpg"), &data("right*.jpg"), (9, 6), 0.025, &out).unwrap();
    println!(
        "pairs {} skipped {} stereo RMS {:.4} px (left {:.4}, right {:.4}) rectified row error {:.4} px",
        report.used.len(),
        report.skipped.len(),
        report.calibration.rms_px,
        report.left_rms_px,
        report.right_rms_px,
        report.rectified_row_error_px
    );
    for pair in &report.used {
        println!(
            "  {} {:.3} / {:.3} px",
            pair.left.file_name().unwrap().display(),
            pair.left_rms_px,
            pair.right_rms_px
        );
    }
    assert_eq!(report.used.len(), 13, "skipped: {:?}", report.skipped);
    assert!(report.skipped.is_empty());
    assert!(report.calibration.rms_px < 0.5, "stereo RMS {} px", report.calibration.rms_px);
    assert!(report.rectified_row_error_px < 0.5, "row error {} px", report.rectified_row_error_px);
    let baseline_m = -report.calibration.t[0];
    assert!(baseline_m > 0.0, "right camera is to the right of the left one: T = {:?}", report.calibration.t);

    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.starts_with("%YAML:1.0"), "OpenCV FileStorage YAML header: {}", &text[..40]);
    assert!(text.contains("K1: !!opencv-matrix") && text.contains("Q: !!opencv-matrix"), "{text}");
    let loaded = StereoCalibration::load(&out).unwrap();
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(1.0);
    assert!(
        close(loaded.q[2][3], report.calibration.q[2][3]) && close(loaded.rms_px, report.calibration.rms_px)
    );
    assert_eq!(loaded.image_width, 640);
    assert_eq!(loaded.depth_scale, 1.0);
}

#[test]
fn images_without_a_board_are_listed_not_fatal() {
    let dir = scratch("mixed");
    std::fs::create_dir_all(&dir).unwrap();
    for n in ["01", "02", "03", "04", "05"] {
        for side in ["left", "right"] {
            std::fs::copy(data(&format!("{side}{n}.jpg")), dir.join(format!("{side}{n}.jpg"))).unwrap();
        }
    }
    // A blank grey pair: no board in either image.
    let blank =
        opencv::core::Mat::new_rows_cols_with_default(480, 640, opencv::core::CV_8UC1, 128.into()).unwrap();
    opencv::imgcodecs::imwrite_def(dir.join("left99.png"), &blank).unwrap();
    opencv::imgcodecs::imwrite_def(dir.join("right99.png"), &blank).unwrap();
    let (left, right) = (dir.join("left*").display().to_string(), dir.join("right*").display().to_string());
    let report = calibrate(&left, &right, (9, 6), 0.025, &dir.join("out.yaml")).unwrap();
    assert_eq!(report.used.len(), 5);
    assert_eq!(report.skipped.len(), 1);
    assert!(report.skipped[0].left.ends_with("left99.png"));
    assert_eq!(report.skipped[0].reason, "board not found in either image");
}

#[test]
fn bad_inputs_are_typed_errors_naming_the_input() {
    let out = scratch("never.yaml");
    let err = calibrate(&data("nothing*.jpg"), &data("right*.jpg"), (9, 6), 0.025, &out).unwrap_err();
    assert!(matches!(err, VisionError::Params(_)) && err.to_string().contains("nothing*.jpg"), "{err}");
    let err = calibrate(&data("left0*.jpg"), &data("right*.jpg"), (9, 6), 0.025, &out).unwrap_err();
    assert!(err.to_string().contains("9 files match") && err.to_string().contains("13 match"), "{err}");
    let err = calibrate(&data("left*.jpg"), &data("right*.jpg"), (9, 6), -1.0, &out).unwrap_err();
    assert!(err.to_string().contains("square size"), "{err}");

    let corrupt = scratch("corrupt.yaml");
    std::fs::write(&corrupt, "%YAML:1.0\n---\nimage_width: 640\nK1: 3\n").unwrap();
    let err = StereoCalibration::load(&corrupt).unwrap_err();
    assert!(err.to_string().contains("corrupt.yaml"), "{err}");
    std::fs::write(&corrupt, "not yaml at all {{{").unwrap();
    assert!(StereoCalibration::load(&corrupt).is_err());
    assert!(
        StereoCalibration::load(Path::new("/nonexistent/stereo.yaml"))
            .unwrap_err()
            .to_string()
            .contains("no such")
    );
}

#[test]
fn depth_scale_is_the_least_squares_ratio_of_true_to_measured() {
    // Thesis §3.2.5: 1.55 m measured for 1.60 m, 2.50 m measured for 2.57 m.
    let s = depth_scale_from_references(&[(1.55, 1.60), (2.50, 2.57)]).unwrap();
    assert!((s - 1.0289).abs() < 1e-3, "{s}");
    assert!(depth_scale_from_references(&[]).is_err());
    assert!(depth_scale_from_references(&[(0.0, 1.0)]).is_err());
}

#[test]
fn a_calibrated_pipeline_rectifies_and_ranges_the_board() {
    let out = scratch("pipeline.yaml");
    let report = calibrate(&data("left*.jpg"), &data("right*.jpg"), (9, 6), 0.025, &out).unwrap();
    let geometry = StereoGeometry::from_calibration(&report.calibration).unwrap();
    assert!(
        (geometry.baseline_m + report.calibration.t[0]).abs() < 1e-3 * geometry.baseline_m,
        "{geometry:?}"
    );
    let base = Path::new(&out).parent().unwrap();
    let mut pipeline =
        StereoPipeline::new(&Geometry::Calibration("pipeline.yaml".into()), &PipelineParams::default(), base)
            .unwrap();
    let (left, right) = (
        load_gray(Path::new(&data("left01.jpg"))).unwrap(),
        load_gray(Path::new(&data("right01.jpg"))).unwrap(),
    );
    let frame =
        StereoFrame::new(Time(9), 1, 640, 480, gray_bytes(&left).unwrap(), gray_bytes(&right).unwrap())
            .unwrap();
    let grid = pipeline.process(&frame).unwrap();
    assert_eq!((grid.time, grid.frame_sequence), (Time(9), 1));
    let ranged: Vec<f32> = grid.regions.iter().flatten().filter_map(|r| r.nearest_m).collect();
    println!("board view 01: nearest per region {:?}", grid.regions.map(|row| row.map(|r| r.nearest_m)));
    assert!(!ranged.is_empty() && ranged.iter().all(|z| z.is_finite() && *z > 0.0), "{grid:?}");
    let wrong_size = StereoFrame::new(Time(0), 2, 320, 240, vec![0; 320 * 240], vec![0; 320 * 240]).unwrap();
    assert!(matches!(pipeline.process(&wrong_size), Err(VisionError::Input(_))));
}
