//! Stereo depth from two images: the vision crate's pure core on a rectified pair, no graph.
//!
//! Three steps, each one call: semi-global matching gives a disparity per pixel of the left
//! image (`Matcher::compute`, in px), the camera geometry turns disparity into depth along the
//! optical axis (`DepthMap::from_disparity`: Z = B·f / (d + doffs), in m), and
//! `write_depth_png` draws the depth as a colour picture (yellow near, dark purple far, black
//! where no depth was found). The stereo actor runs these same steps on every camera frame.
//!
//! ```sh
//! cargo run --example stereo_from_images                       # Middlebury's teddy pair
//! cargo run --example stereo_from_images -- --left L.png --right R.png \
//!     --focal-px 700 --baseline-m 0.12 --out depth.png        # a pair of your own
//! ```
//!
//! The default pair is Middlebury 2003 "teddy" (450×375, already rectified), the vision tests'
//! data: see `actors/vision/tests/data/README.md` for its source, licence and citation.
//! Middlebury publishes no calibration for it, so the geometry is the nominal one of
//! `config/bench-stereo-files.toml` (f = 450 px, B = 0.1 m): the depths are those of a camera
//! with that geometry. With the default pair the example also prints Middlebury's ground-truth
//! disparity beside its own at each pixel. A pair that is not rectified must be rectified
//! first (`kestrel calibrate`, then `kestrel disparity --calib`).

use std::error::Error;
use std::path::{Path, PathBuf};

use clap::Parser;
use kestrel_vision::image::load_gray;
use kestrel_vision::{
    DepthMap, DepthRange, GroundTruth, Matcher, MatcherParams, StereoGeometry, write_depth_png,
};

/// The vendored pair (Middlebury 2003 teddy) and its ground truth.
const TEDDY: &str = "actors/vision/tests/data/middlebury2003_teddy";
/// Teddy's ground-truth file holds disparity × 4.
const TEDDY_GT_SCALE: f32 = 4.0;

#[derive(Parser)]
#[command(about = "Stereo depth from a rectified image pair")]
struct Args {
    /// Left image of a rectified pair (default: Middlebury's teddy, im2.png).
    #[arg(long, requires = "right")]
    left: Option<PathBuf>,
    /// Right image of the same pair (default: teddy's im6.png).
    #[arg(long, requires = "left")]
    right: Option<PathBuf>,
    /// Focal length of the rectified cameras (px).
    #[arg(long, default_value_t = 450.0)]
    focal_px: f64,
    /// Distance between the two cameras' optical centres (m).
    #[arg(long, default_value_t = 0.1)]
    baseline_m: f64,
    /// Largest disparity searched (px, a multiple of 16): objects nearer than
    /// focal·baseline/this are not matched.
    #[arg(long, default_value_t = 64)]
    num_disparities: i32,
    /// Where the colour depth picture goes.
    #[arg(long, default_value = "depth.png")]
    out: PathBuf,
}

fn main() -> Result<(), Box<dyn Error>> {
    let args = Args::parse();
    let teddy = Path::new(env!("CARGO_MANIFEST_DIR")).join(TEDDY);
    let (left, right) = match (&args.left, &args.right) {
        (Some(l), Some(r)) => (l.clone(), r.clone()),
        _ => (teddy.join("im2.png"), teddy.join("im6.png")),
    };
    // Ground truth only for the pair it belongs to.
    let ground_truth = match args.left {
        None => Some(GroundTruth::load(&teddy.join("disp2.pgm"), TEDDY_GT_SCALE)?),
        Some(_) => None,
    };

    // 1. Disparity: how far (px) each left-image pixel moved in the right image. Matching runs
    //    on grey images; a pixel without a reliable match has no disparity (None), never 0.
    let (left_image, right_image) = (load_gray(&left)?, load_gray(&right)?);
    let matcher_params = MatcherParams::default().with_num_disparities(args.num_disparities);
    let disparity = Matcher::new(&matcher_params)?.compute(&left_image, &right_image)?;
    println!(
        "{} × {} px, disparity found for {:.1} % of the pixels",
        disparity.width,
        disparity.height,
        disparity.density() * 100.0
    );

    // 2. Depth from disparity with the rectified cameras' geometry. `checked` refuses one that
    //    cannot give depths (a zero focal length, a negative baseline).
    let geometry = StereoGeometry {
        focal_px: args.focal_px,
        cx_px: (disparity.width as f64 - 1.0) / 2.0,
        cy_px: (disparity.height as f64 - 1.0) / 2.0,
        baseline_m: args.baseline_m,
        doffs_px: 0.0,
        depth_scale: 1.0,
    }
    .checked()?;
    let depth = DepthMap::from_disparity(&disparity, &geometry);

    // 3. A picture for people: colour follows 1/depth between the range's ends.
    let range = DepthRange::default();
    write_depth_png(&depth, range, &args.out)?;
    println!(
        "wrote {} (yellow at {} m and nearer, dark purple at {} m and beyond, black: no depth)",
        args.out.display(),
        range.near_m,
        range.far_m
    );

    // The depth at a few pixels: the centre and a point halfway to each corner.
    let (w, h) = (disparity.width, disparity.height);
    let pixels =
        [(w / 2, h / 2), (w / 4, h / 4), (3 * w / 4, h / 4), (w / 4, 3 * h / 4), (3 * w / 4, 3 * h / 4)];
    for (x, y) in pixels {
        let found = match (disparity.get(x, y), depth.get(x, y)) {
            (Some(d), Some(z)) => format!("disparity {d:6.2} px, depth {z:5.2} m"),
            _ => "no disparity, no depth".to_owned(),
        };
        let truth = ground_truth
            .as_ref()
            .and_then(|gt| gt.values.get(y * gt.width + x).copied())
            .filter(|d| !d.is_nan())
            .map(|d| format!("; ground truth {d:6.2} px"))
            .unwrap_or_default();
        println!("pixel ({x:3}, {y:3}): {found}{truth}");
    }
    Ok(())
}
