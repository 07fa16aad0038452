//! `kestrel calibrate`: stereo calibration from chessboard image pairs into an OpenCV
//! FileStorage YAML, with a per-image report.

use kestrel_vision::{calibrate, depth_scale_from_references};

use crate::cli::CalibrateArgs;

/// Calibrates, reports per image, and applies the optional depth-scale correction.
pub fn run(args: CalibrateArgs) -> Result<(), String> {
    let board = parse_board(&args.board)?;
    if !(args.square.is_finite() && args.square > 0.0) {
        return Err(format!("--square {}: expected a positive side length in metres", args.square));
    }
    let references = args.reference.iter().map(|r| parse_reference(r)).collect::<Result<Vec<_>, _>>()?;
    let mut report =
        calibrate(&args.left, &args.right, board, args.square, &args.out).map_err(|e| e.to_string())?;
    for pair in &report.used {
        println!(
            "{} + {}: reprojection {:.3} px (left), {:.3} px (right)",
            pair.left.display(),
            pair.right.display(),
            pair.left_rms_px,
            pair.right_rms_px
        );
    }
    for pair in &report.skipped {
        println!("skipped {} + {}: {}", pair.left.display(), pair.right.display(), pair.reason);
    }
    if !references.is_empty() {
        let scale = depth_scale_from_references(&references).map_err(|e| e.to_string())?;
        report.calibration.depth_scale = scale;
        report.calibration.save(&args.out).map_err(|e| e.to_string())?;
        println!("depth scale correction {scale:.4} from {} reference distances", references.len());
    }
    println!(
        "{} of {} pairs used; RMS reprojection: left {:.3} px, right {:.3} px, stereo {:.3} px; rectified rows differ by {:.3} px on average",
        report.used.len(),
        report.used.len() + report.skipped.len(),
        report.left_rms_px,
        report.right_rms_px,
        report.calibration.rms_px,
        report.rectified_row_error_px
    );
    println!("wrote {}", args.out.display());
    Ok(())
}

/// `9x6` → (9, 6): inner corners per row and per column.
fn parse_board(text: &str) -> Result<(u32, u32), String> {
    let parsed =
        text.split_once(['x', 'X']).and_then(|(c, r)| Some((c.trim().parse().ok()?, r.trim().parse().ok()?)));
    match parsed {
        Some((c, r)) if c >= 2 && r >= 2 => Ok((c, r)),
        _ => Err(format!("--board {text}: expected inner corners as COLSxROWS, e.g. 9x6")),
    }
}

/// `MEASURED:TRUE` in metres.
fn parse_reference(text: &str) -> Result<(f64, f64), String> {
    let parsed =
        text.split_once(':').and_then(|(m, t)| Some((m.trim().parse().ok()?, t.trim().parse().ok()?)));
    match parsed {
        Some((m, t)) if f64::is_finite(m) && f64::is_finite(t) && m > 0.0 && t > 0.0 => Ok((m, t)),
        _ => Err(format!("--reference {text}: expected MEASURED:TRUE distances in metres, e.g. 2.43:2.50")),
    }
}
