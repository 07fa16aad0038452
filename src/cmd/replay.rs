//! `kestrel replay`: run the estimator over a recorded flight — a PX4 ULog or one of our MCAP
//! logs — and write its estimate beside the log's own (PX4 EKF2's, or the recorded `nav_state`)
//! and beside ground truth where a simulator logged it.

use std::io::{BufWriter, Write};

use kestrel::flight_log::FlightLog;
use kestrel::replay::{Scores, replay, write_csv};
use kestrel_estimator::EkfParams;

use crate::cli::ReplayArgs;

/// Replays `args.log` into the CSV `args.out` and prints the summary.
pub fn run(args: ReplayArgs) -> Result<(), String> {
    let params = match &args.params {
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
            toml::from_str::<EkfParams>(&text).map_err(|e| format!("{}: {e}", path.display()))?
        }
        None => EkfParams::default(),
    };
    let log = FlightLog::open(&args.log).map_err(|e| e.to_string())?;
    let result = replay(&log, params).map_err(|e| e.to_string())?;
    let file = std::fs::File::create(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let mut out = BufWriter::new(file);
    write_csv(&result, &mut out)
        .and_then(|()| out.flush())
        .map_err(|e| format!("{}: {e}", args.out.display()))?;
    let s = &result.summary;
    let mut summary = format!("{} rows against {}; aligned at {:.2} s", s.rows, s.primary, s.aligned_at_s);
    for scores in [&s.vs_estimate, &s.vs_truth].into_iter().flatten() {
        summary.push_str(&format!("; {}", describe(scores)));
    }
    summary.push_str(&format!("; {} samples rejected", s.rejected));
    if let Some(damage) = &result.log_damage {
        summary.push_str(&format!("; the log is damaged or cut short, replayed what was readable: {damage}"));
    }
    println!("{summary}");
    Ok(())
}

/// One reference's RMS differences, e.g. `RMS vs EKF2: roll 0.06°, …, horizontal 0.01 m`.
fn describe(s: &Scores) -> String {
    let deg = |v: Option<f64>| v.map_or("n/a".to_owned(), |v| format!("{v:.2}°"));
    let m = |v: Option<f64>| v.map_or("n/a".to_owned(), |v| format!("{v:.2} m"));
    format!(
        "RMS vs {}: roll {}, pitch {}, yaw {}, attitude {}, height {}, horizontal {}",
        s.label,
        deg(s.rms_roll_deg),
        deg(s.rms_pitch_deg),
        deg(s.rms_yaw_deg),
        deg(s.rms_attitude_deg),
        m(s.rms_height_m),
        m(s.rms_horizontal_m)
    )
}
