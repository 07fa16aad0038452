//! Replay a PX4 flight log through Kestrel's EKF and set its estimate beside PX4 EKF2's.
//!
//! The estimator is a pure core: `Ekf::push_imu`, `push_gps`, `push_baro` and `push_mag` take
//! sensor samples, `Ekf::nav_state` gives the estimate. No graph, no clock: the log is read
//! with `kestrel::flight_log::FlightLog` (a PX4 ULog or one of our MCAP logs, told by its first
//! bytes) into our own message types, each sample stamped with the time it was *measured*, and
//! fed to the filter in the order the vehicle *received* them, so every sensor's lag is
//! replayed as it was flown.
//!
//! ```sh
//! cargo run --example replay_px4_log                              # PX4 SITL take-off and landing
//! cargo run --example replay_px4_log -- --log flight.ulg --plot replay.png
//! ```
//!
//! The default log is `tests/data/px4/px4_sitl_takeoff_land.ulg` (PX4 SITL, 31 s: take-off to
//! 2.2 m and landing; source and licence in `tests/data/px4/README.md`). Attitude and height
//! are compared here; `kestrel replay --log FILE --out FILE.csv` also compares horizontal
//! position and ground truth, and its RMS figures for roll, pitch, yaw and height are the
//! ones this example prints (tests/docs_examples.rs holds them equal).

use std::error::Error;
use std::path::{Path, PathBuf};

use clap::Parser;
use kestrel::flight_log::{FlightLog, Place, Replayed, nearest};
use kestrel_estimator::{Ekf, EkfParams};
use kestrel_proto::Time;
use kestrel_proto::attitude::{angle_difference_rad, euler_rad, unit_quaternion, wxyz};
use plotters::prelude::*;

#[derive(Parser)]
#[command(about = "Replay a PX4 ULog through Kestrel's EKF and compare with the log's own estimate")]
struct Args {
    /// The flight log (PX4 ULog, or a Kestrel MCAP log).
    #[arg(long)]
    log: Option<PathBuf>,
    /// Also draw height and attitude, ours against the log's, into this PNG.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Seconds between the rows of the printed table.
    #[arg(long, default_value_t = 2.0)]
    every_s: f64,
}

/// Our estimate after one IMU sample.
struct Ours {
    time: Time,
    rpy_deg: [f64; 3],
    /// Down from our origin (m).
    down_m: f64,
}

/// Ours beside the log's estimate at one instant the log holds an estimate.
struct Row {
    t_s: f64,
    ours: [f64; 4],
    /// Roll, pitch, yaw (deg) and down (m) of the log's estimate; `None` where it has none.
    theirs: [Option<f64>; 4],
}

/// Our estimate is set beside the log's when one came within this much of the other (µs): ours
/// come at the IMU rate, so a few IMU periods.
const MAX_GAP_US: u64 = 10_000;

fn main() -> Result<(), Box<dyn Error>> {
    let args = Args::parse();
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = args.log.clone().unwrap_or_else(|| repo.join("tests/data/px4/px4_sitl_takeoff_land.ulg"));
    let log = FlightLog::open(&path)?;
    println!("{}: {:?} log with these sensor topics:", path.display(), log.format());
    for topic in log.sensors() {
        println!("  {:<24} {:>6} samples ({:?})", topic.name, topic.samples.len(), topic.kind);
    }

    // 1. Every sensor sample, in the order the vehicle received them. A log with two IMUs (or
    //    two of anything) replays the first of each kind, as the vehicle flew on it.
    let mut samples: Vec<&(Time, Replayed)> = Vec::new();
    for (i, topic) in log.sensors().iter().enumerate() {
        if log.sensors()[..i].iter().all(|earlier| earlier.kind != topic.kind) {
            samples.extend(&topic.samples);
        }
    }
    samples.sort_by_key(|(received, _)| *received);
    // Times are printed from the first sample on (a ULog counts from boot, or from 1970 in SITL).
    let start = samples.first().map_or(Time::ZERO, |(received, _)| *received);
    let since_start_s = |t: Time| t.saturating_since(start).as_secs_f64();

    // 2. A fresh EKF with our defaults, overridden by what the log says the vehicle used (PX4's
    //    GPS delay, the magnetic declination), then every sample in turn. The filter answers
    //    with a `nav_state` once it has aligned (level and heading found while still).
    let mut ekf = Ekf::new(log.settings().apply(EkfParams::default()))?;
    let mut track = Vec::with_capacity(samples.len());
    let mut refused = 0;
    for (_, sample) in samples {
        let pushed = match sample {
            Replayed::Imu(imu) => ekf.push_imu(imu),
            Replayed::Gps(fix) => ekf.push_gps(fix),
            Replayed::Baro(baro) => ekf.push_baro(baro),
            Replayed::Mag(mag) => ekf.push_mag(mag),
            Replayed::Battery(_) => Ok(()),
        };
        // A sample the filter refuses (not finite, out of order, too old to fuse: the
        // `InputError` says which) changes nothing; the replay counts it and goes on.
        if pushed.is_err() {
            refused += 1;
        }
        if let (Replayed::Imu(_), Some(nav)) = (sample, ekf.nav_state()) {
            track.push(Ours {
                time: nav.time,
                rpy_deg: rpy_deg(nav.attitude)?,
                down_m: nav.position_ned_m[2],
            });
        }
    }
    let Some(first) = track.first() else { return Err("the estimator never aligned on this log".into()) };
    println!("our EKF aligned at {:.2} s; {refused} samples refused", since_start_s(first.time));

    // 3. Beside the log's own estimate at each instant it logged one. EKF2 measures height from
    //    a datum of its own, so heights are compared after removing the difference at the first
    //    instant both have one.
    let (Some(reference), _) = log.references() else {
        return Err("the log holds no estimate to compare with".into());
    };
    let mut height_shift_m = None;
    let mut rows = Vec::new();
    for theirs in &reference.samples {
        let Some(ours) = nearest(&track, |p| p.time, theirs.time.as_micros(), MAX_GAP_US) else { continue };
        let rpy = theirs.attitude.and_then(|q| rpy_deg(q).ok());
        let down = theirs.position.filter(|p| p.vertical_valid).and_then(|p| match p.place {
            Place::Local { ned_m, .. } => Some(ned_m[2]),
            // A point on WGS-84 is simulator truth, not an estimate; `kestrel replay` compares it.
            Place::Global(_) => None,
        });
        let down = if reference.align_height {
            down.map(|d| d - *height_shift_m.get_or_insert(d - ours.down_m))
        } else {
            down
        };
        rows.push(Row {
            t_s: since_start_s(theirs.time),
            ours: [ours.rpy_deg[0], ours.rpy_deg[1], ours.rpy_deg[2], ours.down_m],
            theirs: [rpy.map(|a| a[0]), rpy.map(|a| a[1]), rpy.map(|a| a[2]), down],
        });
    }

    let ours_theirs = format!("ours / {}", reference.label);
    println!("\n{:>8}  {:^17}  {:^17}  {:^17}  {:^15}", "time", "roll °", "pitch °", "yaw °", "height m");
    println!("{:>8}  {ours_theirs:^17}  {ours_theirs:^17}  {ours_theirs:^17}  {ours_theirs:^15}", "s");
    let mut next_s = f64::NEG_INFINITY;
    for row in &rows {
        if row.t_s >= next_s {
            let cell = |k: usize| match row.theirs[k] {
                Some(v) => format!("{:7.2} / {v:7.2}", row.ours[k]),
                None => format!("{:7.2} /     n/a", row.ours[k]),
            };
            // Height is up, down negated.
            let height = match row.theirs[3] {
                Some(d) => format!("{:6.2} / {:6.2}", -row.ours[3], -d),
                None => format!("{:6.2} /    n/a", -row.ours[3]),
            };
            println!("{:8.1}  {}  {}  {}  {height}", row.t_s, cell(0), cell(1), cell(2));
            next_s = row.t_s + args.every_s;
        }
    }

    // RMS differences; yaw wraps at ±180°.
    let rms = |k: usize| {
        let diffs: Vec<f64> = rows
            .iter()
            .filter_map(|r| r.theirs[k].map(|v| (r.ours[k], v)))
            .map(|(a, b)| {
                if k < 3 { angle_difference_rad(a.to_radians(), b.to_radians()).to_degrees() } else { a - b }
            })
            .collect();
        let n = diffs.len().max(1) as f64;
        (!diffs.is_empty()).then(|| (diffs.iter().map(|d| d * d).sum::<f64>() / n).sqrt())
    };
    let show = |v: Option<f64>, unit: &str| v.map_or("n/a".to_owned(), |v| format!("{v:.2}{unit}"));
    println!(
        "\nRMS vs {} over {} instants: roll {}, pitch {}, yaw {}, height {}",
        reference.label,
        rows.len(),
        show(rms(0), "°"),
        show(rms(1), "°"),
        show(rms(2), "°"),
        show(rms(3), " m")
    );

    if let Some(out) = &args.plot {
        plot(&rows, reference.label, out)?;
        println!("wrote {}", out.display());
    }
    Ok(())
}

/// Roll, pitch, yaw (deg) of a body-to-NED quaternion `[w, x, y, z]`, normalised first.
fn rpy_deg(q: [f64; 4]) -> Result<[f64; 3], Box<dyn Error>> {
    Ok(euler_rad(wxyz(&unit_quaternion(q)?)).map(f64::to_degrees))
}

/// Four panels (roll, pitch, yaw, height), ours in blue and the log's in red.
fn plot(rows: &[Row], label: &str, out: &Path) -> Result<(), Box<dyn Error>> {
    // Text needs a font; an embedded one draws the same on a machine without any.
    static FONT: &[u8] = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/fonts/DejaVuSans.ttf"));
    plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
        .map_err(|_| "cannot load the font")?;
    let root = BitMapBackend::new(out, (1280, 1200)).into_drawing_area();
    root.fill(&WHITE)?;
    let t_end = rows.last().map_or(1.0, |r| r.t_s);
    let panels = ["roll (°)", "pitch (°)", "yaw (°)", "height (m)"];
    for (k, (area, name)) in root.split_evenly((4, 1)).iter().zip(panels).enumerate() {
        // Height is drawn up, as people read it.
        let value = |v: f64| if k == 3 { -v } else { v };
        let ours: Vec<(f64, f64)> = rows.iter().map(|r| (r.t_s, value(r.ours[k]))).collect();
        let theirs: Vec<(f64, f64)> =
            rows.iter().filter_map(|r| r.theirs[k].map(|v| (r.t_s, value(v)))).collect();
        let (lo, hi) =
            ours.iter().chain(&theirs).fold((f64::MAX, f64::MIN), |(lo, hi), p| (lo.min(p.1), hi.max(p.1)));
        let pad = ((hi - lo) * 0.1).max(0.1);
        let mut chart = ChartBuilder::on(area)
            .caption(name, ("sans-serif", 20))
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(rows.first().map_or(0.0, |r| r.t_s)..t_end, (lo - pad)..(hi + pad))?;
        chart
            .configure_mesh()
            .x_desc("time since the log's first sample (s)")
            .label_style(("sans-serif", 14))
            .draw()?;
        chart
            .draw_series(LineSeries::new(ours, BLUE.stroke_width(2)))?
            .label("Kestrel EKF")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLUE.stroke_width(2)));
        chart
            .draw_series(LineSeries::new(theirs, RED.stroke_width(1)))?
            .label(label)
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RED.stroke_width(1)));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()?;
    }
    root.present()?;
    Ok(())
}
