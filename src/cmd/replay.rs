//! `kestrel replay`: run the estimator over a recorded flight and write its estimate beside the
//! log's own — PX4's EKF2 in a ULog, or in one of our MCAP logs the recorded `nav_state` and the
//! simulator's `ground_truth`.

use std::io::{BufWriter, Write};
use std::path::Path;

use kestrel::recorder::{LogReader, RawRecord};
use kestrel_estimator::{Ekf, EkfParams, replay_ulog, write_csv};
use kestrel_proto::Message;
use kestrel_proto::attitude::euler_rad;
use kestrel_proto::geo::{Geodetic, LocalFrame};
use kestrel_proto::messages::{BaroSample, GpsFix, GroundTruth, ImuSample, MagSample, NavState};

use crate::cli::ReplayArgs;

/// Replays `args.log` (`.ulg` or `.mcap`) into the CSV `args.out`.
pub fn run(args: ReplayArgs) -> Result<(), String> {
    let params = match &args.params {
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
            toml::from_str::<EkfParams>(&text).map_err(|e| format!("{}: {e}", path.display()))?
        }
        None => EkfParams::default(),
    };
    let file = std::fs::File::create(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let mut out = BufWriter::new(file);
    let extension = args.log.extension().and_then(|e| e.to_str()).unwrap_or_default();
    let summary = match extension {
        "ulg" => {
            let result = replay_ulog(&args.log, &params).map_err(|e| e.to_string())?;
            write_csv(&result, &mut out).map_err(|e| format!("{}: {e}", args.out.display()))?;
            let s = &result.summary;
            let damage = result.log_damage.as_ref().map(|d| format!("; {d}, replayed what came before"));
            format!(
                "{} rows; aligned at {:.2} s; RMS vs EKF2: roll {:.2}°, pitch {:.2}°, yaw {:.2}°, height {}, horizontal {}{}",
                s.rows,
                s.aligned_at_s,
                s.rms_roll_vs_px4_deg,
                s.rms_pitch_vs_px4_deg,
                s.rms_yaw_vs_px4_deg,
                metres(s.rms_height_vs_px4_m),
                metres(s.rms_horizontal_vs_px4_m),
                damage.unwrap_or_default()
            )
        }
        "mcap" => replay_mcap(&args.log, params, &mut out)?,
        _ => {
            return Err(format!(
                "{}: expected a PX4 ULog (.ulg) or a Kestrel log (.mcap)",
                args.log.display()
            ));
        }
    };
    out.flush().map_err(|e| format!("{}: {e}", args.out.display()))?;
    println!("{summary}");
    Ok(())
}

fn metres(v: Option<f64>) -> String {
    v.map_or("n/a".to_owned(), |v| format!("{v:.2} m"))
}

/// Feeds the log's sensor topics to a fresh estimator in recorded order, and writes one row per
/// ground-truth (or, without it, recorded `nav_state`) sample once the estimator has aligned.
fn replay_mcap(path: &Path, params: EkfParams, out: &mut impl Write) -> Result<String, String> {
    let log = LogReader::open(path).map_err(|e| e.to_string())?;
    let damage =
        log.damage().map(|d| format!("; the log is damaged or cut short, replayed what was readable: {d}"));
    let mut ekf = Ekf::new(params).map_err(|e| e.to_string())?;
    let has_truth = log.topics().iter().any(|t| t.schema_name == GroundTruth::TYPE_NAME);
    let io = |e: std::io::Error| e.to_string();
    writeln!(
        out,
        "time_s,roll_deg,pitch_deg,yaw_deg,north_m,east_m,down_m,ref_roll_deg,ref_pitch_deg,ref_yaw_deg,ref_north_m,ref_east_m,ref_down_m"
    )
    .map_err(io)?;
    let (mut rows, mut rejected, mut sq_horizontal) = (0u64, 0u64, 0.0);
    for record in log.raw() {
        let record = record.map_err(|e| e.to_string())?;
        let pushed = match &*record.schema_name {
            n if n == ImuSample::TYPE_NAME => ekf.push_imu(&decode(path, &record)?),
            n if n == GpsFix::TYPE_NAME => ekf.push_gps(&decode(path, &record)?),
            n if n == BaroSample::TYPE_NAME => ekf.push_baro(&decode(path, &record)?),
            n if n == MagSample::TYPE_NAME => ekf.push_mag(&decode(path, &record)?),
            n if (has_truth && n == GroundTruth::TYPE_NAME) || (!has_truth && n == NavState::TYPE_NAME) => {
                let Some((ours, frame)) = ekf.nav_state().zip(ekf.frame().copied()) else { continue };
                let reference = if has_truth {
                    let t: GroundTruth = decode(path, &record)?;
                    let here = Geodetic { lat_deg: t.lat_deg, lon_deg: t.lon_deg, alt_m: t.alt_msl_m };
                    (t.attitude, frame.to_ned(here))
                } else {
                    let n: NavState = decode(path, &record)?;
                    (n.attitude, reference_in(&frame, &n))
                };
                let (ea, eb) = (
                    euler_rad(ours.attitude).map(f64::to_degrees),
                    euler_rad(reference.0).map(f64::to_degrees),
                );
                let (p, q) = (ours.position_ned_m, reference.1);
                sq_horizontal += (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
                rows += 1;
                writeln!(
                    out,
                    "{:.6},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
                    ours.time.as_secs_f64(),
                    ea[0],
                    ea[1],
                    ea[2],
                    p[0],
                    p[1],
                    p[2],
                    eb[0],
                    eb[1],
                    eb[2],
                    q[0],
                    q[1],
                    q[2]
                )
                .map_err(io)?;
                Ok(())
            }
            _ => Ok(()),
        };
        if pushed.is_err() {
            rejected += 1;
        }
    }
    if rows == 0 {
        return Err(format!("{}: the estimator never aligned on this log (no rows written)", path.display()));
    }
    Ok(format!(
        "{rows} rows against {}; RMS horizontal difference {:.3} m; {rejected} samples rejected{}",
        if has_truth { "ground truth" } else { "the recorded nav_state" },
        (sq_horizontal / rows as f64).sqrt(),
        damage.unwrap_or_default()
    ))
}

/// Decodes one recorded message, naming the log and topic when it does not fit the type.
fn decode<T: Message>(path: &Path, record: &RawRecord) -> Result<T, String> {
    serde_json::from_slice(&record.data).map_err(|e| {
        format!("{}: a `{}` message does not decode as {}: {e}", path.display(), record.topic, T::TYPE_NAME)
    })
}

/// A recorded NavState's position expressed in our estimator's frame.
fn reference_in(frame: &LocalFrame, nav: &NavState) -> [f64; 3] {
    match nav.origin {
        Some(origin) => frame.to_ned(LocalFrame::new(origin).to_geodetic(nav.position_ned_m)),
        None => nav.position_ned_m,
    }
}
