//! `kestrel report` on a flight recorded in-process from the default graph (`config/sim.toml`,
//! lockstep clock): the plots are real PNGs with content, the summary's numbers are plausible,
//! and bad input is refused with an error that says what was wrong. A synthetic flight past
//! obstacles, written through the recorder, gets the path and avoider figures.

mod support;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::Duration;

use kestrel::flight_plots::{PLOT_SIZE_PX, PlotError, PlotFile, ReportSummary, SUMMARY_FILE, write_report};
use kestrel::recorder::{LogReader, Recorder};
use kestrel::{LoadedConfig, Registry, RunOptions, run};
use kestrel_proto::Time;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{
    AvoidanceCommand, BaroSample, GpsFix, GpsFixType, GroundTruth, NavState, NavValidity, Obstacle,
    ObstacleMap, Setpoint, SetpointTarget, TrajectorySetpoint,
};
use support::flights;

/// A fresh scratch path for this test process.
fn scratch(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("kestrel-report-{}-{name}", std::process::id()))
}

/// A 20 s simulated flight (the vehicle at rest: the default graph has no controller yet),
/// recorded once for all tests.
fn recorded_log() -> &'static Path {
    static LOG: OnceLock<PathBuf> = OnceLock::new();
    LOG.get_or_init(|| {
        let path = scratch("sim.mcap");
        let mut config =
            LoadedConfig::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("config/sim.toml")).unwrap();
        flights::without_link_sockets(&mut config);
        let options = RunOptions {
            duration: Some(Duration::from_secs(20)),
            speedup: Some(0.0),
            record: Some(path.clone()),
            ..Default::default()
        };
        run(&config, &Registry::standard(), options).unwrap();
        path
    })
}

#[test]
fn a_simulated_flight_gives_every_plot_and_a_plausible_summary() {
    let out = scratch("plots");
    let summary = write_report(recorded_log(), &out).unwrap();
    println!("{summary}");

    let names: Vec<&str> =
        summary.plots.iter().map(|p| p.file.file_name().unwrap().to_str().unwrap()).collect();
    assert_eq!(
        names,
        [
            "position_north.png",
            "position_east.png",
            "position_zoom.png",
            "velocity_ned.png",
            "height.png",
            "climb_rate.png",
            "truth_position.png",
            "truth_velocity.png",
            "attitude_error.png",
        ]
    );
    for plot in &summary.plots {
        assert_drawn(plot);
    }
    // The simulator put its (empty) obstacle map in the log; an empty world draws no map.
    let topics = LogReader::open(recorded_log()).unwrap().topics();
    assert!(topics.iter().any(|t| t.topic == "obstacle_map" && t.schema_name == "kestrel.ObstacleMap"));
    assert_eq!((summary.obstacles.as_ref(), summary.avoidance.as_ref()), (None, None));

    let gps = summary.vs_gps.as_ref().expect("GPS errors");
    assert!(gps.samples > 80, "{gps:?}");
    assert!(gps.rms_horizontal_m.is_finite() && gps.rms_horizontal_m < 3.0, "{gps:?}");
    assert!(gps.rms_velocity_north_m_s < 0.5 && gps.rms_velocity_down_m_s < 0.5, "{gps:?}");
    let latency = summary.gps_latency_ms.unwrap();
    assert!((latency - 220.0).abs() < 10.0, "GPS lags 220 ms in the simulator, measured {latency} ms");
    let baro = summary.vs_baro.as_ref().expect("barometer errors");
    assert!(baro.samples > 150 && baro.rms_height_m < 2.0, "{baro:?}");
    assert!(baro.rms_climb_rate_m_s.is_some_and(|r| r < 2.0), "{baro:?}");
    let truth = summary.vs_truth.as_ref().expect("ground-truth errors");
    assert!(truth.samples > 800, "{truth:?}");
    assert!(truth.rms_horizontal_m < 1.0 && truth.rms_vertical_m < 1.0, "{truth:?}");
    assert!(truth.rms_velocity_m_s < 0.3, "{truth:?}");
    assert!(truth.rms_roll_pitch_deg.is_some_and(|d| d < 2.0), "{truth:?}");
    assert!(truth.rms_yaw_deg.is_some_and(|d| d < 5.0), "{truth:?}");
    assert!((summary.duration_s - 20.0).abs() < 0.5, "{}", summary.duration_s);

    let written: ReportSummary =
        serde_json::from_slice(&std::fs::read(out.join(SUMMARY_FILE)).unwrap()).unwrap();
    assert_eq!(written, summary);
    let _ = std::fs::remove_dir_all(&out);
}

/// The PNG has the plot size, is not blank, is not flooded with ink, and has a title in text.
fn assert_drawn(plot: &PlotFile) {
    let image = png::decode(&std::fs::read(&plot.file).unwrap())
        .unwrap_or_else(|e| panic!("{}: {e}", plot.file.display()));
    assert_eq!((image.width, image.height), PLOT_SIZE_PX, "{}", plot.file.display());
    assert_eq!((plot.width_px, plot.height_px), PLOT_SIZE_PX);
    let luma = image.luma();
    let mean = luma.iter().map(|&l| f64::from(l)).sum::<f64>() / luma.len() as f64;
    let variance = luma.iter().map(|&l| (f64::from(l) - mean).powi(2)).sum::<f64>() / luma.len() as f64;
    assert!(variance > 200.0, "{} looks blank (luma variance {variance:.1})", plot.file.display());
    let inked = luma.iter().filter(|&&l| l < 200).count() as f64 / luma.len() as f64;
    assert!((0.01..0.5).contains(&inked), "{}: {:.1} % of pixels inked", plot.file.display(), inked * 100.0);
    // The title is text in the top band: dark pixels there mean the embedded font rendered.
    let title_band = &luma[..image.width as usize * 36];
    assert!(
        title_band.iter().filter(|&&l| l < 100).count() > 200,
        "{}: no title text drawn",
        plot.file.display()
    );
}

/// Seconds the synthetic flight lasts; it flies north at [`SPEED_M_S`], 5 m up.
const FLIGHT_S: u64 = 20;
const SPEED_M_S: f64 = 2.0;

/// A tree 3 m east of the synthetic leg (at 20 m north) and a plain wall across its end.
fn synthetic_obstacles() -> Vec<Obstacle> {
    vec![
        Obstacle::Cylinder { base_ne_m: [20.0, 3.0], radius_m: 1.0, height_m: 8.0 },
        Obstacle::Wall {
            from_ne_m: [44.0, -8.0],
            to_ne_m: [44.0, 8.0],
            height_m: 4.0,
            thickness_m: 0.3,
            textured: false,
        },
    ]
}

/// Writes a flight north along east 0 at 5 m height with every topic the report reads, plus,
/// when `with_obstacles`, the obstacle map and avoidance commands; one collision at 10 s.
fn synthetic_flight(path: &Path, with_obstacles: bool) {
    let home = Geodetic { lat_deg: 6.7971, lon_deg: 79.9017, alt_m: 20.0 };
    let frame = LocalFrame::new(home);
    let recorder = Recorder::create(path).unwrap();
    let nav = recorder.channel::<NavState>("nav_state").unwrap();
    let gps = recorder.channel::<GpsFix>("gps").unwrap();
    let baro = recorder.channel::<BaroSample>("baro").unwrap();
    let truth = recorder.channel::<GroundTruth>("ground_truth").unwrap();
    let setpoint = recorder.channel::<Setpoint>("setpoint").unwrap();
    if with_obstacles {
        let map = recorder.channel::<ObstacleMap>("obstacle_map").unwrap();
        map.record(Time::ZERO, &ObstacleMap { time: Time::ZERO, home, obstacles: synthetic_obstacles() });
    }
    let avoidance = recorder.channel::<AvoidanceCommand>("avoidance_command").unwrap();
    for tick in 0..=FLIGHT_S * 100 {
        let time = Time::from_micros(tick * 10_000);
        let t_s = tick as f64 / 100.0;
        let position_ned_m = [SPEED_M_S * t_s, 0.0, -5.0];
        let velocity_ned_m_s = [SPEED_M_S, 0.0, 0.0];
        let here = frame.to_geodetic(position_ned_m);
        let mut state =
            NavState::exact(time, [1.0, 0.0, 0.0, 0.0], [0.0; 3], velocity_ned_m_s, position_ned_m);
        state.origin = Some(home);
        state.valid = NavValidity::ALL;
        nav.record(time, &state);
        if tick % 20 == 0 {
            let fix = GpsFix {
                time,
                fix_type: GpsFixType::Fix3d,
                satellites: 12,
                lat_deg: here.lat_deg,
                lon_deg: here.lon_deg,
                alt_msl_m: here.alt_m,
                vel_ned_m_s: velocity_ned_m_s,
                h_acc_m: 1.0,
                v_acc_m: 1.5,
                s_acc_m_s: 0.2,
            };
            gps.record(time, &fix);
            let target = TrajectorySetpoint {
                position_ned_m: [Some(position_ned_m[0] + 1.0), Some(0.0), Some(-5.0)],
                ..TrajectorySetpoint::default()
            };
            let command = Setpoint {
                time,
                armed: true,
                target: SetpointTarget::Trajectory(target),
                landing: false,
                failed_motor: None,
            };
            setpoint.record(time, &command);
        }
        if tick % 10 == 0 {
            baro.record(
                time,
                &BaroSample { time, pressure_pa: 101_000.0, altitude_m: here.alt_m, temperature_c: 25.0 },
            );
        }
        if tick % 2 == 0 {
            let tree_m = (position_ned_m[0] - 20.0).hypot(3.0) - 1.0;
            let sample = GroundTruth {
                time,
                position_ned_m,
                velocity_ned_m_s,
                acceleration_ned_m_s2: [0.0; 3],
                attitude: [1.0, 0.0, 0.0, 0.0],
                angular_velocity_rad_s: [0.0; 3],
                lat_deg: here.lat_deg,
                lon_deg: here.lon_deg,
                alt_msl_m: here.alt_m,
                landed: false,
                crashed: false,
                collisions: u32::from(t_s >= 10.0),
                clearance_m: with_obstacles.then_some(tree_m),
            };
            truth.record(time, &sample);
        }
        if with_obstacles && tick % AVOIDANCE_TICKS == 0 {
            let near = tree_share(position_ned_m[0]);
            let mut command = AvoidanceCommand { time, ..AvoidanceCommand::default() };
            command.near_shares[1][2] = near;
            command.near_shares[1][1] = near / 3.0;
            command.velocity_frd_m_s = [-0.5 * f64::from(near), -1.2 * f64::from(near), 0.0];
            avoidance.record(time, &command);
        }
    }
    recorder.finish().unwrap();
}

/// Ticks (10 ms) between avoidance commands: about 15 Hz, as the stereo camera runs.
const AVOIDANCE_TICKS: u64 = 7;

/// Share of near pixels in the right region with the vehicle `north_m` along the leg: the tree
/// fills the right of the view as it comes near (the avoider steers left).
fn tree_share(north_m: f64) -> f32 {
    (1.0 - (north_m - 17.0).abs() / 5.0).max(0.0) as f32
}

#[test]
fn a_flight_past_obstacles_draws_the_map_and_the_avoider() {
    let log = scratch("obstacles.mcap");
    synthetic_flight(&log, true);
    let out = scratch("obstacle-plots");
    let summary = write_report(&log, &out).unwrap();
    println!("{summary}");

    let names: Vec<&str> =
        summary.plots.iter().map(|p| p.file.file_name().unwrap().to_str().unwrap()).collect();
    assert_eq!(names[names.len() - 3..], ["path_top.png", "path_side.png", "avoidance.png"], "{names:?}");
    for plot in &summary.plots[names.len() - 3..] {
        assert_drawn(plot);
    }
    let encounters = summary.obstacles.as_ref().expect("obstacle encounters");
    assert_eq!((encounters.obstacles, encounters.collisions), (2, 1), "{encounters:?}");
    assert_eq!(encounters.collision_times_s, [10.0], "{encounters:?}");
    // Abeam of the tree: 3 m to its axis, 1 m radius.
    assert!(encounters.min_clearance_m.is_some_and(|c| (c - 2.0).abs() < 1e-9), "{encounters:?}");
    assert!((encounters.path_length_m - SPEED_M_S * FLIGHT_S as f64).abs() < 1e-6, "{encounters:?}");
    let avoider = summary.avoidance.as_ref().expect("avoider activity");
    assert_eq!(avoider.commands, FLIGHT_S * 100 / AVOIDANCE_TICKS + 1, "{avoider:?}");
    let largest_share = (0..=FLIGHT_S * 100)
        .step_by(AVOIDANCE_TICKS as usize)
        .map(|tick| f64::from(tree_share(SPEED_M_S * tick as f64 / 100.0)))
        .fold(0.0, f64::max);
    assert!(largest_share > 0.9, "the leg passes the tree");
    assert_eq!(
        avoider.max_abs_correction_frd_m_s,
        [0.5 * largest_share, 1.2 * largest_share, 0.0],
        "{avoider:?}"
    );

    let written: ReportSummary =
        serde_json::from_slice(&std::fs::read(out.join(SUMMARY_FILE)).unwrap()).unwrap();
    assert_eq!(written, summary);
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_file(&log);
}

#[test]
fn a_flight_without_an_obstacle_map_skips_the_map_and_the_avoider() {
    let log = scratch("no-obstacles.mcap");
    synthetic_flight(&log, false);
    let out = scratch("no-obstacle-plots");
    let summary = write_report(&log, &out).unwrap();
    let _ = std::fs::remove_file(&log);
    let drawn = |name: &str| summary.plots.iter().any(|p| p.file.ends_with(name));
    assert!(drawn("truth_position.png"), "{:?}", summary.plots);
    for skipped in ["path_top.png", "path_side.png", "avoidance.png"] {
        assert!(!drawn(skipped) && !out.join(skipped).exists(), "{skipped} drawn without its data");
    }
    assert_eq!((summary.obstacles, summary.avoidance), (None, None));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_missing_log_is_named_in_the_error() {
    let missing = scratch("no-such-flight.mcap");
    let error = write_report(&missing, &scratch("unused")).unwrap_err();
    assert!(matches!(error, PlotError::Log(_)), "{error:?}");
    assert!(error.to_string().contains(&*missing.to_string_lossy()), "{error}");
    assert!(!scratch("unused").exists(), "no output directory for a failed report");
}

#[test]
fn a_log_without_the_estimate_says_what_is_missing() {
    let path = scratch("baro-only.mcap");
    let recorder = Recorder::create(&path).unwrap();
    let baro = recorder.channel::<BaroSample>("baro").unwrap();
    for i in 0..20u64 {
        let time = Time::from_micros(i * 100_000);
        baro.record(
            time,
            &BaroSample { time, pressure_pa: 101_000.0, altitude_m: 20.0, temperature_c: 25.0 },
        );
    }
    recorder.finish().unwrap();

    let error = write_report(&path, &scratch("baro-only")).unwrap_err();
    let text = error.to_string();
    let _ = std::fs::remove_file(&path);
    assert!(matches!(error, PlotError::MissingTopic { type_name: "kestrel.NavState", .. }), "{error:?}");
    assert!(text.contains(&*path.to_string_lossy()) && text.contains("baro (kestrel.BaroSample)"), "{text}");
}

#[test]
fn the_command_writes_the_plots_and_names_a_missing_log() {
    let kestrel = || std::process::Command::new(env!("CARGO_BIN_EXE_kestrel"));
    let out = scratch("cli-plots");
    let run = kestrel().arg("report").arg(recorded_log()).arg("--out").arg(&out).output().unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(out.join(SUMMARY_FILE).exists() && out.join("height.png").exists());
    let _ = std::fs::remove_dir_all(&out);

    let missing = scratch("cli-missing.mcap");
    let run = kestrel().arg("report").arg(&missing).arg("--out").arg(scratch("cli-out")).output().unwrap();
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains(&*missing.to_string_lossy()), "{stderr}");
}

/// PNG decoding through the `png` crate, independent of the encoder that wrote the plots.
mod png {
    pub struct Image {
        pub width: u32,
        pub height: u32,
        channels: usize,
        pixels: Vec<u8>,
    }

    impl Image {
        /// Per-pixel luma (ITU-R BT.601), 0–255.
        pub fn luma(&self) -> Vec<u8> {
            self.pixels
                .chunks(self.channels)
                .map(|p| match p {
                    [r, g, b, ..] => {
                        ((299 * u32::from(*r) + 587 * u32::from(*g) + 114 * u32::from(*b)) / 1000) as u8
                    }
                    [grey, ..] => *grey,
                    [] => 0,
                })
                .collect()
        }
    }

    pub fn decode(bytes: &[u8]) -> Result<Image, String> {
        let mut reader = ::png::Decoder::new(bytes).read_info().map_err(|e| e.to_string())?;
        let mut pixels = vec![0; reader.output_buffer_size()];
        let frame = reader.next_frame(&mut pixels).map_err(|e| e.to_string())?;
        if frame.bit_depth != ::png::BitDepth::Eight {
            return Err(format!("{:?} bits per channel, expected 8", frame.bit_depth));
        }
        pixels.truncate(frame.buffer_size());
        Ok(Image { width: frame.width, height: frame.height, channels: frame.color_type.samples(), pixels })
    }
}
