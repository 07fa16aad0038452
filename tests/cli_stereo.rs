//! `kestrel stereo` and `kestrel disparity --depth-out` as a person runs them, on the
//! repository's stereo test data.

use std::path::{Path, PathBuf};
use std::process::Command;

use kestrel::recorder::LogReader;
use kestrel_proto::messages::DepthGrid;

fn kestrel() -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_kestrel"));
    cmd.current_dir(env!("CARGO_MANIFEST_DIR")).env_remove("RUST_LOG");
    cmd
}

/// Runs `cmd`, fails the test (showing stderr) unless it exits 0, and returns its stdout.
fn succeed(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

fn data(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("actors/vision/tests/data").join(path)
}

/// An 8-bit PNG as `(width, height, channels, samples)`, read with the `png` crate (not the
/// OpenCV that wrote it).
fn read_png(path: &Path) -> (usize, usize, usize, Vec<u8>) {
    let mut decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().unwrap();
    let mut samples = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut samples).unwrap();
    samples.truncate(info.buffer_size());
    let (w, h) = (info.width as usize, info.height as usize);
    (w, h, samples.len() / (w * h), samples)
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kestrel-stereo-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The `p`-th percentile (nearest rank) of the ground-truth depths in the centre region of
/// Middlebury's cones (GT value = 4 · disparity, 0 unknown), for focal length `f` px and
/// baseline `b` m: the reference `kestrel stereo`'s centre `nearest_m` must come near.
fn cones_centre_truth_percentile(f: f64, b: f64, p: f64) -> f64 {
    let (w, h, channels, truth) = read_png(&data("middlebury2003_cones/disp2.png"));
    assert_eq!(channels, 1);
    let (x0, x1) = ((w as f64 / 3.0).round() as usize, (2.0 * w as f64 / 3.0).round() as usize);
    let (y0, y1) = ((h as f64 / 3.0).round() as usize, (2.0 * h as f64 / 3.0).round() as usize);
    let mut depths: Vec<f64> = (y0..y1)
        .flat_map(|y| (x0..x1).map(move |x| (x, y)))
        .map(|(x, y)| f64::from(truth[y * w + x]) / 4.0)
        .filter(|&d| d > 0.0)
        .map(|d| f * b / d)
        .collect();
    depths.sort_by(f64::total_cmp);
    depths[((p / 100.0 * depths.len() as f64).ceil() as usize).max(1) - 1]
}

#[test]
fn stereo_on_a_folder_prints_grids_and_stage_timings() {
    let dir = temp_dir("cones");
    let config = dir.join("stereo.toml");
    // Middlebury's quarter-size cones with an assumed 450 px focal length and 10 cm baseline:
    // depth = 45 / disparity (m).
    std::fs::write(
        &config,
        "geometry = { rectified = { focal_px = 450.0, cx_px = 224.5, cy_px = 187.0, baseline_m = 0.1 } }\n",
    )
    .unwrap();
    let out = succeed(
        kestrel()
            .args(["stereo", "--left", "im2.png", "--right", "im6.png", "--source"])
            .arg(data("middlebury2003_cones"))
            .arg("--config")
            .arg(&config),
    );
    println!("{out}");
    assert!(out.contains("frame 0 at "), "{out}");
    assert!(out.contains("1 frames in"), "{out}");
    for stage in ["capture", "rectify", "match", "depth", "grid", "total"] {
        let line = out.lines().find(|l| l.starts_with(stage)).unwrap_or_else(|| panic!("no {stage} line"));
        let figures: Vec<f64> = line.split_whitespace().skip(1).map(|v| v.parse().unwrap()).collect();
        assert_eq!(figures.len(), 3, "{line}");
        assert!(figures[0] >= 0.0 && figures[0] <= figures[1] && figures[1] <= figures[2], "{line}");
    }
    let centre = out.lines().find(|l| l.trim_start().starts_with("centre")).unwrap();
    let nearest: Vec<f64> =
        centre.split("nearest_m").nth(1).unwrap().split_whitespace().map(|v| v.parse().unwrap()).collect();
    let truth = cones_centre_truth_percentile(450.0, 0.1, 2.0);
    println!("centre nearest {} m, ground truth 2nd percentile {truth:.3} m", nearest[1]);
    assert!((nearest[1] - truth).abs() < 0.1 * truth, "centre nearest {} m vs truth {truth} m", nearest[1]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn stereo_rectifies_raw_pairs_from_a_graph_config_and_records() {
    let dir = temp_dir("chessboard");
    let calibration = dir.join("stereo.yaml");
    let pattern =
        |side: &str| data("opencv_stereo_calib_9x6").join(format!("{side}*.jpg")).display().to_string();
    succeed(
        kestrel()
            .args(["calibrate", "--left", &pattern("left"), "--right", &pattern("right"), "--out"])
            .arg(&calibration),
    );
    // A graph config: the stereo actor's params are taken, its calibration path resolved
    // against the config's folder.
    let config = dir.join("graph.toml");
    std::fs::write(
        &config,
        "[actors.stereo]\ntype = \"stereo\"\ninputs.stereo_frame = { topic = \"stereo_frame\", mailbox = \"latest\" }\n\
         params = { geometry = { calibration = \"stereo.yaml\" }, pipeline = { grid = { threshold_m = 2.0 } } }\n",
    )
    .unwrap();
    let log = dir.join("stereo.mcap");
    let out = succeed(
        kestrel()
            .args(["stereo", "--quiet", "--frames", "5", "--source"])
            .arg(data("opencv_stereo_calib_9x6"))
            .arg("--config")
            .arg(&config)
            .arg("--record")
            .arg(&log),
    );
    assert!(out.contains("5 frames in") && !out.contains("frame 0 at"), "{out}");
    let reader = LogReader::open(&log).unwrap();
    let grids = reader.read::<DepthGrid>("depth_grid").unwrap();
    assert_eq!(grids.len(), 5);
    assert!(
        grids
            .iter()
            .enumerate()
            .all(|(i, g)| g.message.frame_sequence == i as u64 && g.message.threshold_m == 2.0)
    );
    let timings = reader.topics().into_iter().find(|t| t.topic == "stereo_timing").unwrap();
    assert_eq!(timings.message_count, 5);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn stereo_names_a_bad_source_and_a_bad_config() {
    let out = kestrel()
        .args(["stereo", "--source", "/nonexistent/frames", "--config", "Cargo.toml"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("Cargo.toml"), "{err}");
    let dir = temp_dir("bad");
    let config = dir.join("stereo.toml");
    std::fs::write(
        &config,
        "geometry = { rectified = { focal_px = 450.0, cx_px = 0.0, cy_px = 0.0, baseline_m = 0.1 } }\n",
    )
    .unwrap();
    let out = kestrel()
        .args(["stereo", "--source", "/nonexistent/frames", "--config"])
        .arg(&config)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("/nonexistent/frames"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn disparity_writes_a_colour_depth_picture() {
    let dir = temp_dir("depth");
    let (pfm, png) = (dir.join("cones.pfm"), dir.join("depth.png"));
    let out = succeed(
        kestrel()
            .arg("disparity")
            .arg("--left")
            .arg(data("middlebury2003_cones/im2.png"))
            .arg("--right")
            .arg(data("middlebury2003_cones/im6.png"))
            .arg("--out")
            .arg(&pfm)
            .args(["--focal-px", "450", "--baseline-m", "0.1", "--depth-range", "0.5:10", "--depth-out"])
            .arg(&png),
    );
    assert!(out.contains("depth.png") && out.contains("0.5 m") && out.contains("10 m"), "{out}");
    let disparity = kestrel_vision::disparity_file::read_pfm(&pfm).unwrap();
    let (w, h, channels, image) = read_png(&png);
    assert_eq!((w, h, channels), (450, 375, 3));
    let pixel = |x: usize, y: usize| {
        let i = 3 * (y * w + x);
        [image[i], image[i + 1], image[i + 2]]
    };
    // Rec. 601 luma; viridis brightens monotonically from far to near.
    let luma = |[r, g, b]: [u8; 3]| 0.114 * f64::from(b) + 0.587 * f64::from(g) + 0.299 * f64::from(r);
    let mut checked = 0;
    for y in (0..375).step_by(25) {
        for x in (0..450).step_by(25) {
            match disparity.get(x, y) {
                None => assert_eq!(pixel(x, y), [0, 0, 0], "({x}, {y}) has no disparity: black"),
                Some(d) if d > 5.0 => {
                    assert_ne!(pixel(x, y), [0, 0, 0], "({x}, {y})");
                    checked += 1;
                }
                Some(_) => {}
            }
        }
    }
    assert!(checked > 100, "{checked}");
    // The nearest and farthest valid pixels on one row: nearer is brighter.
    let row: Vec<(usize, f32)> = (0..450).filter_map(|x| disparity.get(x, 200).map(|d| (x, d))).collect();
    let near = row.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    let far = row.iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    assert!(luma(pixel(near.0, 200)) > luma(pixel(far.0, 200)) + 20.0, "near {near:?} far {far:?}");
    let err = kestrel()
        .args(["disparity", "--left", "a.png", "--right", "b.png", "--out", "x.pfm", "--depth-out", "d.png"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&err.stderr).contains("--focal-px"), "{err:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
