//! `kestrel disparity`: the disparity of one image pair, scored against ground truth when given.

use kestrel_vision::{MatcherParams, disparity};

use crate::cli::DisparityArgs;

/// Computes, writes and (with `--gt`) scores one disparity map.
pub fn run(args: DisparityArgs) -> Result<(), String> {
    let mut matcher = match &args.matcher {
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
            toml::from_str::<MatcherParams>(&text).map_err(|e| format!("{}: {e}", path.display()))?
        }
        None => MatcherParams::default(),
    };
    if let Some(n) = args.num_disparities {
        match &mut matcher {
            MatcherParams::Sgbm(p) => p.num_disparities = n,
            MatcherParams::Bm(p) => p.num_disparities = n,
        }
    }
    let ground_truth = match (&args.gt, args.gt_scale) {
        (Some(path), Some(scale)) if scale.is_finite() && scale > 0.0 => Some((path.as_path(), scale)),
        (Some(_), Some(scale)) => return Err(format!("--gt-scale {scale}: expected a positive factor")),
        (Some(_), None) => {
            return Err("--gt needs --gt-scale (ground-truth value = disparity × scale)".into());
        }
        (None, _) => None,
    };
    let report = disparity(&args.left, &args.right, args.calib.as_deref(), ground_truth, &matcher, &args.out)
        .map_err(|e| e.to_string())?;
    println!("wrote {}", args.out.display());
    if let Some(s) = report.scores {
        println!(
            "bad-1 {:.2} %, bad-2 {:.2} % ({:.2} % outside the left band), end-point error {:.3} px, density {:.1} % over {} pixels with ground truth",
            s.bad1_pct, s.bad2_pct, s.bad2_outside_band_pct, s.epe_px, s.density_pct, s.known_px
        );
    }
    Ok(())
}
