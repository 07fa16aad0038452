//! `kestrel disparity`: the disparity of one image pair, scored against ground truth when given,
//! and optionally its depth as a colour picture.

use kestrel_vision::{
    DepthMap, DepthRange, MatcherParams, StereoCalibration, StereoGeometry, disparity, write_depth_png,
};

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
    // Checked before the matching so a bad flag fails fast.
    let depth_out = match &args.depth_out {
        Some(path) => Some((path, geometry(&args)?, depth_range(&args.depth_range)?)),
        None => None,
    };
    let report = disparity(&args.left, &args.right, args.calib.as_deref(), ground_truth, &matcher, &args.out)
        .map_err(|e| e.to_string())?;
    println!("wrote {}", args.out.display());
    if let Some((path, geometry, range)) = depth_out {
        let depth = DepthMap::from_disparity(&report.disparity, &geometry);
        write_depth_png(&depth, range, path).map_err(|e| e.to_string())?;
        println!(
            "wrote {} (viridis on 1/depth: yellow at {} m and nearer, dark purple at {} m and beyond, black = no depth)",
            path.display(),
            range.near_m,
            range.far_m
        );
    }
    if let Some(s) = report.scores {
        println!(
            "bad-1 {:.2} %, bad-2 {:.2} % ({:.2} % outside the left band), end-point error {:.3} px, density {:.1} % over {} pixels with ground truth",
            s.bad1_pct, s.bad2_pct, s.bad2_outside_band_pct, s.epe_px, s.density_pct, s.known_px
        );
    }
    Ok(())
}

/// The geometry `--depth-out` converts disparity with: the calibration's, or the flags'.
fn geometry(args: &DisparityArgs) -> Result<StereoGeometry, String> {
    match (&args.calib, args.focal_px, args.baseline_m) {
        (Some(path), _, _) => StereoCalibration::load(path)
            .and_then(|c| StereoGeometry::from_calibration(&c))
            .map_err(|e| e.to_string()),
        (None, Some(focal_px), Some(baseline_m)) => StereoGeometry {
            focal_px,
            cx_px: 0.0,
            cy_px: 0.0,
            baseline_m,
            doffs_px: args.doffs_px,
            depth_scale: 1.0,
        }
        .checked()
        .map_err(|e| format!("--focal-px/--baseline-m: {e}")),
        _ => Err("--depth-out needs the geometry: --calib, or --focal-px and --baseline-m".into()),
    }
}

/// Parses `--depth-range NEAR:FAR` (m).
fn depth_range(text: &str) -> Result<DepthRange, String> {
    let bad = || format!("--depth-range {text}: expected NEAR:FAR in metres, e.g. 0.5:20");
    let (near, far) = text.split_once(':').ok_or_else(bad)?;
    let range = DepthRange {
        near_m: near.trim().parse().map_err(|_| bad())?,
        far_m: far.trim().parse().map_err(|_| bad())?,
    };
    range.checked().map_err(|e| format!("--depth-range {text}: {e}"))
}
