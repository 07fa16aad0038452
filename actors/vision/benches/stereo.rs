//! Stereo timings at VGA (the Middlebury reindeer crop, 640×480) for 64 and 128 disparities:
//! rectify, our SGBM, StereoBM, the depth grid and the whole frame → `DepthGrid` in each
//! pipeline configuration, with OpenCV's StereoSGBM 3-way (the data README's parameters) as
//! the reference in the same run.
//!
//! Criterion measures each stage; a summary then prints p50/p95 over repeated single runs and
//! the ratio to the reference, and scores every pipeline configuration and both OpenCV
//! references (3-way, and the README's default-mode SGBM) on the Middlebury pairs (bad-2 %
//! over all ground-truth pixels, invalid counted as bad), so speed and accuracy come from the
//! same build and run. `cargo bench -p kestrel-vision --bench stereo`.

use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use kestrel_proto::Time;
use kestrel_vision::image::{crop, gray_bytes, load_gray};
use kestrel_vision::texture::TextureFilter;
use kestrel_vision::{
    BmParams, DepthMap, DisparityMap, Geometry, GroundTruth, Matcher, MatcherParams, PipelineParams,
    Rectifier, SgbmMode, SgbmParams, StereoCalibration, StereoFrame, StereoGeometry, StereoPipeline,
    TextureParams, calibrate, depth_grid, score,
};
use opencv::calib3d::{StereoSGBM, StereoSGBM_MODE_SGBM, StereoSGBM_MODE_SGBM_3WAY};
use opencv::core::{Mat, Ptr};
use opencv::prelude::*;

struct Inputs {
    left: Mat,
    right: Mat,
    frame: StereoFrame,
    calibration: StereoCalibration,
}

fn inputs() -> Inputs {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let vga = |f: &str| {
        crop(&load_gray(&data.join("middlebury2005_reindeer_half").join(f)).unwrap(), 0, 37, 640, 480)
            .unwrap()
    };
    let (left, right) = (vga("view1.png"), vga("view5.png"));
    let frame =
        StereoFrame::new(Time(0), 0, 640, 480, gray_bytes(&left).unwrap(), gray_bytes(&right).unwrap())
            .unwrap();
    let calib = |side: &str| data.join(format!("opencv_stereo_calib_9x6/{side}*.jpg")).display().to_string();
    let out = std::env::temp_dir().join("kestrel-vision-bench-stereo.yaml");
    let calibration = calibrate(&calib("left"), &calib("right"), (9, 6), 0.025, &out).unwrap().calibration;
    Inputs { left, right, frame, calibration }
}

/// OpenCV's StereoSGBM with the data README's parameters, in `mode`.
fn opencv_reference(num_disparities: i32, mode: i32) -> Ptr<StereoSGBM> {
    StereoSGBM::create(0, num_disparities, 5, 8 * 25, 32 * 25, 1, 0, 10, 100, 2, mode).unwrap()
}

/// The pipeline configurations compared: name and parameters at 64 disparities.
fn configurations() -> Vec<(&'static str, PipelineParams)> {
    let with =
        |downscale, row_downscale| PipelineParams { downscale, row_downscale, ..PipelineParams::default() };
    vec![
        ("frame_to_grid", with(1, 1)),
        ("frame_to_grid_rows2", with(1, 2)),
        ("frame_to_grid_downscale2", with(2, 1)),
    ]
}

fn pipeline(
    calibration: &StereoCalibration,
    num_disparities: i32,
    params: &PipelineParams,
) -> StereoPipeline {
    let params =
        PipelineParams { matcher: params.matcher.with_num_disparities(num_disparities), ..params.clone() };
    StereoPipeline::calibrated(calibration, &params).unwrap()
}

/// Every timed case: a name and a closure doing one run.
fn cases(inputs: &Inputs, num_disparities: i32) -> Vec<(String, Box<dyn FnMut() + '_>)> {
    let rectifier = Rectifier::new(&inputs.calibration).unwrap();
    let (mut rl, mut rr) = (Mat::default(), Mat::default());
    let mut ours = Matcher::new(&MatcherParams::default().with_num_disparities(num_disparities)).unwrap();
    let bm_params = MatcherParams::Bm(BmParams { num_disparities, ..BmParams::default() });
    let mut bm = Matcher::new(&bm_params).unwrap();
    let mut reference = opencv_reference(num_disparities, StereoSGBM_MODE_SGBM_3WAY);
    let mut raw = Mat::default();
    let disparity = ours.compute(&inputs.left, &inputs.right).unwrap();
    let geometry = *pipeline(&inputs.calibration, num_disparities, &PipelineParams::default()).geometry();
    let depth = DepthMap::from_disparity(&disparity, &geometry);
    let mut texture = TextureFilter::new(&TextureParams::default()).unwrap().unwrap();
    let mut textured = disparity.clone();
    let grid_params = PipelineParams::default().grid;
    let n = num_disparities;
    let mut cases: Vec<(String, Box<dyn FnMut() + '_>)> = vec![
        (
            format!("opencv_sgbm_3way_reference/{n}"),
            Box::new(move || reference.compute(&inputs.left, &inputs.right, &mut raw).unwrap()),
        ),
        (
            format!("rectify/{n}"),
            Box::new(move || rectifier.rectify_into(&inputs.left, &inputs.right, &mut rl, &mut rr).unwrap()),
        ),
        (
            format!("sgbm/{n}"),
            Box::new(move || drop(black_box(ours.compute(&inputs.left, &inputs.right).unwrap()))),
        ),
        (
            format!("bm/{n}"),
            Box::new(move || drop(black_box(bm.compute(&inputs.left, &inputs.right).unwrap()))),
        ),
        (format!("texture/{n}"), Box::new(move || texture.apply(&inputs.left, &mut textured).unwrap())),
        (
            format!("depth/{n}"),
            Box::new(move || drop(black_box(DepthMap::from_disparity(&disparity, &geometry)))),
        ),
        (
            format!("grid/{n}"),
            Box::new(move || drop(black_box(depth_grid(&depth, &geometry, &grid_params, Time(0), 0)))),
        ),
    ];
    for (name, params) in configurations() {
        let mut p = pipeline(&inputs.calibration, num_disparities, &params);
        cases.push((
            format!("{name}/{n}"),
            Box::new(move || drop(black_box(p.process(&inputs.frame).unwrap()))),
        ));
    }
    cases
}

fn percentile(sorted: &[Duration], p: f64) -> f64 {
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i].as_secs_f64() * 1e3
}

fn stereo(c: &mut Criterion) {
    let inputs = inputs();
    for n in [64, 128] {
        let mut group = c.benchmark_group(format!("vga_{n}"));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(2));
        for (name, mut run) in cases(&inputs, n) {
            group.bench_function(name, |b| b.iter(&mut run));
        }
        group.finish();
    }
    // Percentiles over single runs, the reference first for the ratio.
    let runs = if std::env::args().any(|a| a == "--test") { 3 } else { 60 };
    println!("\nstage (VGA)                          p50 ms   p95 ms   ratio to OpenCV SGBM-3WAY: p50  p95");
    for n in [64, 128] {
        let (mut reference_p50, mut reference_p95) = (f64::NAN, f64::NAN);
        for (name, mut run) in cases(&inputs, n) {
            let mut times: Vec<Duration> = (0..runs)
                .map(|_| {
                    let start = Instant::now();
                    run();
                    start.elapsed()
                })
                .collect();
            times.sort();
            let (p50, p95) = (percentile(&times, 0.5), percentile(&times, 0.95));
            if name.starts_with("opencv") {
                (reference_p50, reference_p95) = (p50, p95);
            }
            println!(
                "{name:36} {p50:7.2}  {p95:7.2}   {:.2}  {:.2}",
                p50 / reference_p50,
                p95 / reference_p95
            );
        }
    }
    overhead(&inputs, runs);
    accuracy();
}

/// OpenCV's StereoSGBM with the pipeline's own matcher parameters (the defaults) at
/// `num_disparities`: the bare matcher inside frame → grid.
fn opencv_as_pipeline(num_disparities: i32) -> Ptr<StereoSGBM> {
    let p = SgbmParams { num_disparities, ..SgbmParams::default() };
    assert_eq!(p.mode, SgbmMode::ThreeWay, "the bench builds the pipeline's matcher in 3-way mode");
    StereoSGBM::create(
        p.min_disparity,
        p.num_disparities,
        p.block_size,
        p.p1,
        p.p2,
        p.disp12_max_diff,
        p.pre_filter_cap,
        p.uniqueness_ratio,
        p.speckle_window_size,
        p.speckle_range,
        StereoSGBM_MODE_SGBM_3WAY,
    )
    .unwrap()
}

/// The pipeline's own cost over the bare matcher at 64 disparities, run alternately so a load
/// change on the shared machine hits all alike: frame → grid against OpenCV's StereoSGBM with
/// the pipeline's parameters on the pair the pipeline matches (rectified), and against the
/// 3-way reference on the raw pair; with the pipeline's stages (its own timings) to say where
/// the rest goes.
fn overhead(inputs: &Inputs, runs: usize) {
    let n = 64;
    let mut reference = opencv_reference(n, StereoSGBM_MODE_SGBM_3WAY);
    let mut bare = opencv_as_pipeline(n);
    let (mut rl, mut rr, mut raw) = (Mat::default(), Mat::default(), Mat::default());
    Rectifier::new(&inputs.calibration)
        .unwrap()
        .rectify_into(&inputs.left, &inputs.right, &mut rl, &mut rr)
        .unwrap();
    let mut p = pipeline(&inputs.calibration, n, &PipelineParams::default());
    let mut times = [const { Vec::new() }; 7];
    for _ in 0..runs {
        let start = Instant::now();
        reference.compute(&inputs.left, &inputs.right, &mut raw).unwrap();
        times[0].push(start.elapsed());
        let start = Instant::now();
        bare.compute(&rl, &rr, &mut raw).unwrap();
        times[1].push(start.elapsed());
        let start = Instant::now();
        black_box(p.process(&inputs.frame).unwrap());
        times[2].push(start.elapsed());
        let t = p.times();
        for (stage, time) in times[3..].iter_mut().zip([t.rectify, t.matching, t.depth, t.grid]) {
            stage.push(time);
        }
    }
    for t in &mut times {
        t.sort();
    }
    let [reference, bare, ours, rectify, matching, depth, grid] =
        times.map(|t| (percentile(&t, 0.5), percentile(&t, 0.95)));
    let percent = |a: f64, b: f64| (a / b - 1.0) * 100.0;
    println!(
        "\npipeline overhead/{n}, alternating runs: frame_to_grid p50 {:.2} ms, p95 {:.2} ms; over OpenCV SGBM-3WAY with its parameters on the rectified pair (p50 {:.2}, p95 {:.2} ms): {:+.1} % p50, {:+.1} % p95; over the reference on the raw pair (p50 {:.2}, p95 {:.2} ms): {:+.1} % p50, {:+.1} % p95",
        ours.0,
        ours.1,
        bare.0,
        bare.1,
        percent(ours.0, bare.0),
        percent(ours.1, bare.1),
        reference.0,
        reference.1,
        percent(ours.0, reference.0),
        percent(ours.1, reference.1),
    );
    println!(
        "  its stages, p50: rectify {:.2} ms, matching and texture check {:.2} ms, depth {:.2} ms, grid {:.2} ms",
        rectify.0, matching.0, depth.0, grid.0
    );
}

/// A Middlebury pair (optionally cropped) with its ground truth, scored at `num_disparities`.
struct Scene {
    name: &'static str,
    left: Mat,
    right: Mat,
    truth: GroundTruth,
    num_disparities: i32,
}

fn scenes() -> Vec<Scene> {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    // Images as grey, ground truth as stored (its values are disparities).
    let load = |dir: &str, f: &str, window: Option<[i32; 4]>| {
        let path = data.join(dir).join(f);
        let image = if f.starts_with("disp") {
            kestrel_vision::image::load_unchanged(&path).unwrap()
        } else {
            load_gray(&path).unwrap()
        };
        match window {
            Some([x, y, w, h]) => crop(&image, x, y, w, h).unwrap(),
            None => image,
        }
    };
    let scene = |name, dir, [l, r, gt]: [&str; 3], scale, num_disparities, window| {
        let truth = GroundTruth::from_scaled(&load(dir, gt, window), scale).unwrap();
        Scene { name, left: load(dir, l, window), right: load(dir, r, window), truth, num_disparities }
    };
    vec![
        scene("cones", "middlebury2003_cones", ["im2.png", "im6.png", "disp2.png"], 4.0, 64, None),
        scene("teddy", "middlebury2003_teddy", ["im2.png", "im6.png", "disp2.pgm"], 4.0, 64, None),
        scene(
            "reindeer",
            "middlebury2005_reindeer_half",
            ["view1.png", "view5.png", "disp1.png"],
            2.0,
            128,
            Some([0, 37, 640, 480]),
        ),
    ]
}

/// bad-2 (%) of every configuration on every scene, the OpenCV references first.
fn accuracy() {
    let scenes = scenes();
    let names: Vec<String> = scenes.iter().map(|s| format!("{:>9}", s.name)).collect();
    println!("\nbad-2 % over all ground truth (invalid = bad)  {}", names.join(""));
    for (name, mode) in [
        ("opencv_sgbm_3way_reference", StereoSGBM_MODE_SGBM_3WAY),
        ("opencv_sgbm_readme", StereoSGBM_MODE_SGBM),
    ] {
        let bad2: Vec<f64> = scenes
            .iter()
            .map(|s| {
                let mut raw = Mat::default();
                opencv_reference(s.num_disparities, mode).compute(&s.left, &s.right, &mut raw).unwrap();
                let d = DisparityMap::from_fixed_point(&raw, 0).unwrap();
                score(&d, &s.truth, s.num_disparities as usize).unwrap().bad2_pct
            })
            .collect();
        print_row(name, &bad2);
    }
    // Middlebury pairs are rectified; any geometry gives the same disparities.
    let geometry = StereoGeometry {
        focal_px: 500.0,
        cx_px: 0.0,
        cy_px: 0.0,
        baseline_m: 0.1,
        doffs_px: 0.0,
        depth_scale: 1.0,
    };
    for (name, params) in configurations() {
        let bad2: Vec<f64> = scenes
            .iter()
            .map(|s| {
                let params = PipelineParams {
                    matcher: params.matcher.with_num_disparities(s.num_disparities),
                    ..params.clone()
                };
                let mut p =
                    StereoPipeline::new(&Geometry::Rectified(geometry), &params, Path::new(".")).unwrap();
                let d = p.full_size_disparity(&s.left, &s.right).unwrap();
                score(&d, &s.truth, s.num_disparities as usize).unwrap().bad2_pct
            })
            .collect();
        print_row(name, &bad2);
    }
}

fn print_row(name: &str, values: &[f64]) {
    let cells: Vec<String> = values.iter().map(|v| format!("{v:9.2}")).collect();
    println!("{name:46} {}", cells.join(""));
}

criterion_group!(benches, stereo);
criterion_main!(benches);
