//! Stereo timings at VGA (the Middlebury reindeer crop, 640×480) for 64 and 128 disparities:
//! rectify, our SGBM, StereoBM, the depth grid and the whole frame → `DepthGrid`, with
//! OpenCV's StereoSGBM 3-way (the data README's parameters) as the reference in the same run.
//!
//! Criterion measures each stage; a summary then prints p50/p95 over repeated single runs and
//! the ratio to the reference. `cargo bench -p kestrel-vision --bench stereo`.

use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use kestrel_proto::Time;
use kestrel_vision::image::{crop, gray_bytes, load_gray};
use kestrel_vision::texture::TextureFilter;
use kestrel_vision::{
    BmParams, DepthMap, Matcher, MatcherParams, PipelineParams, Rectifier, StereoCalibration, StereoFrame,
    StereoPipeline, TextureParams, calibrate, depth_grid,
};
use opencv::calib3d::{StereoSGBM, StereoSGBM_MODE_SGBM_3WAY};
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

fn opencv_reference(num_disparities: i32) -> Ptr<StereoSGBM> {
    StereoSGBM::create(0, num_disparities, 5, 8 * 25, 32 * 25, 1, 0, 10, 100, 2, StereoSGBM_MODE_SGBM_3WAY)
        .unwrap()
}

fn pipeline(calibration: &StereoCalibration, num_disparities: i32, downscale: u32) -> StereoPipeline {
    let params = PipelineParams {
        matcher: MatcherParams::default().with_num_disparities(num_disparities),
        downscale,
        ..PipelineParams::default()
    };
    StereoPipeline::calibrated(calibration, &params).unwrap()
}

/// Every timed case: a name and a closure doing one run.
fn cases(inputs: &Inputs, num_disparities: i32) -> Vec<(String, Box<dyn FnMut() + '_>)> {
    let rectifier = Rectifier::new(&inputs.calibration).unwrap();
    let (mut rl, mut rr) = (Mat::default(), Mat::default());
    let mut ours = Matcher::new(&MatcherParams::default().with_num_disparities(num_disparities)).unwrap();
    let bm_params = MatcherParams::Bm(BmParams { num_disparities, ..BmParams::default() });
    let mut bm = Matcher::new(&bm_params).unwrap();
    let mut reference = opencv_reference(num_disparities);
    let mut raw = Mat::default();
    let mut full = pipeline(&inputs.calibration, num_disparities, 1);
    let mut half = pipeline(&inputs.calibration, num_disparities, 2);
    let disparity = ours.compute(&inputs.left, &inputs.right).unwrap();
    let geometry = *full.geometry();
    let depth = DepthMap::from_disparity(&disparity, &geometry);
    let mut texture = TextureFilter::new(&TextureParams::default()).unwrap().unwrap();
    let mut textured = disparity.clone();
    let grid_params = PipelineParams::default().grid;
    let n = num_disparities;
    vec![
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
        (
            format!("frame_to_grid/{n}"),
            Box::new(move || drop(black_box(full.process(&inputs.frame).unwrap()))),
        ),
        (
            format!("frame_to_grid_downscale2/{n}"),
            Box::new(move || drop(black_box(half.process(&inputs.frame).unwrap()))),
        ),
    ]
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
    println!("\nstage (VGA)                          p50 ms   p95 ms   p50 / OpenCV SGBM-3WAY");
    for n in [64, 128] {
        let mut reference_p50 = f64::NAN;
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
                reference_p50 = p50;
            }
            println!("{name:36} {p50:7.2}  {p95:7.2}   {:.2}", p50 / reference_p50);
        }
    }
}

criterion_group!(benches, stereo);
criterion_main!(benches);
