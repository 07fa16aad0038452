//! `kestrel report` on a flight recorded in-process from the default graph (`config/sim.toml`,
//! lockstep clock): the plots are real PNGs with content, the summary's numbers are plausible,
//! and bad input is refused with an error that says what was wrong.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::Duration;

use kestrel::flight_plots::{PLOT_SIZE_PX, PlotError, ReportSummary, SUMMARY_FILE, write_report};
use kestrel::recorder::Recorder;
use kestrel::{LoadedConfig, Registry, RunOptions, run};
use kestrel_proto::Time;
use kestrel_proto::messages::BaroSample;

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
        let config =
            LoadedConfig::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("config/sim.toml")).unwrap();
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
        let image = png::decode(&std::fs::read(&plot.file).unwrap())
            .unwrap_or_else(|e| panic!("{}: {e}", plot.file.display()));
        assert_eq!((image.width, image.height), PLOT_SIZE_PX, "{}", plot.file.display());
        assert_eq!((plot.width_px, plot.height_px), PLOT_SIZE_PX);
        let luma = image.luma();
        let mean = luma.iter().map(|&l| f64::from(l)).sum::<f64>() / luma.len() as f64;
        let variance = luma.iter().map(|&l| (f64::from(l) - mean).powi(2)).sum::<f64>() / luma.len() as f64;
        assert!(variance > 200.0, "{} looks blank (luma variance {variance:.1})", plot.file.display());
        let inked = luma.iter().filter(|&&l| l < 200).count() as f64 / luma.len() as f64;
        assert!(
            (0.01..0.5).contains(&inked),
            "{}: {:.1} % of pixels inked",
            plot.file.display(),
            inked * 100.0
        );
        // The title is text in the top band: dark pixels there mean the embedded font rendered.
        let title_band = &luma[..image.width as usize * 36];
        assert!(
            title_band.iter().filter(|&&l| l < 100).count() > 200,
            "{}: no title text drawn",
            plot.file.display()
        );
    }

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
