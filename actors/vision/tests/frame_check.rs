//! The frame check on real stereo pairs: every vendored pair (Middlebury cones, teddy, reindeer;
//! OpenCV's 13 calibration pairs) passes, and the same pairs with a capped lens, glare over the
//! centre, a saturated exposure or one lens half covered are each named.

use std::path::{Path, PathBuf};

use kestrel_proto::Time;
use kestrel_proto::messages::StereoFrame;
use kestrel_vision::frame_check::{FrameCheck, FrameCheckParams, FrameFault, ImageStats, Lens};
use kestrel_vision::image::{gray_bytes, load_gray};
use opencv::prelude::*;

fn data(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(path)
}

/// A real pair: name, width, height, left and right grey pixels.
struct Pair {
    name: String,
    width: u32,
    height: u32,
    left: Vec<u8>,
    right: Vec<u8>,
}

fn load(left: &str, right: &str) -> Pair {
    let l = load_gray(&data(left)).expect("left image");
    let r = load_gray(&data(right)).expect("right image");
    assert_eq!((l.cols(), l.rows()), (r.cols(), r.rows()), "{left}");
    Pair {
        name: left.to_owned(),
        width: l.cols() as u32,
        height: l.rows() as u32,
        left: gray_bytes(&l).expect("left pixels"),
        right: gray_bytes(&r).expect("right pixels"),
    }
}

fn real_pairs() -> Vec<Pair> {
    let mut pairs = vec![
        load("middlebury2003_cones/im2.png", "middlebury2003_cones/im6.png"),
        load("middlebury2003_teddy/im2.png", "middlebury2003_teddy/im6.png"),
        load("middlebury2005_reindeer_half/view1.png", "middlebury2005_reindeer_half/view5.png"),
    ];
    for n in [1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14] {
        pairs.push(load(
            &format!("opencv_stereo_calib_9x6/left{n:02}.jpg"),
            &format!("opencv_stereo_calib_9x6/right{n:02}.jpg"),
        ));
    }
    pairs
}

fn check(pair: &Pair, left: &[u8], right: &[u8]) -> Option<FrameFault> {
    let frame = StereoFrame::new(Time::ZERO, 0, pair.width, pair.height, left.to_vec(), right.to_vec())
        .expect("sizes match");
    FrameCheck::new(FrameCheckParams::default()).check(&frame)
}

/// `pixels` with the rectangle of columns `x0..x1`, rows `y0..y1` (shares of the image) blended
/// towards white by `intensity` (0..1): veiling glare, `p + intensity·(255 − p)`.
fn glare(pair: &Pair, pixels: &[u8], rect: [f64; 4], intensity: f64) -> Vec<u8> {
    let (w, h) = (pair.width as usize, pair.height as usize);
    let [x0, y0, x1, y1] = rect;
    let cols = (x0 * w as f64) as usize..(x1 * w as f64) as usize;
    let rows = (y0 * h as f64) as usize..(y1 * h as f64) as usize;
    let mut out = pixels.to_vec();
    for (i, p) in out.iter_mut().enumerate() {
        if rows.contains(&(i / w)) && cols.contains(&(i % w)) {
            *p = (f64::from(*p) + intensity * (255.0 - f64::from(*p))).round() as u8;
        }
    }
    out
}

/// The figures behind the thresholds' defaults (printed with `--nocapture`), and no fault on any
/// real pair.
#[test]
fn no_real_pair_is_called_blind() {
    let params = FrameCheckParams::default();
    for pair in real_pairs() {
        let (w, h) = (pair.width as usize, pair.height as usize);
        let l = ImageStats::measure(&pair.left, w, h, &params);
        let r = ImageStats::measure(&pair.right, w, h, &params);
        let ratio = (l.mean.max(r.mean) + 1.0) / (l.mean.min(r.mean) + 1.0);
        println!(
            "{:45} dark {:.4}/{:.4} saturated {:.4}/{:.4} centre saturated {:.4}/{:.4} mean {:.1}/{:.1} ratio {:.3}",
            pair.name,
            l.dark_share,
            r.dark_share,
            l.saturated_share,
            r.saturated_share,
            l.centre_saturated_share,
            r.centre_saturated_share,
            l.mean,
            r.mean,
            ratio
        );
        assert_eq!(check(&pair, &pair.left, &pair.right), None, "{}", pair.name);
    }
}

/// Each fault applied to each real pair is named: a lens capped (a cap's light leak keeps pixels
/// under 16), glare over the centre (the middle half of the image, full intensity), the sun over
/// the whole image, one lens half covered (its brightness × 0.4).
#[test]
fn each_fault_on_each_real_pair_is_named() {
    for pair in real_pairs() {
        let capped: Vec<u8> = pair.right.iter().map(|p| p / 16).collect();
        assert_eq!(
            check(&pair, &pair.left, &capped),
            Some(FrameFault::LensCapped(Lens::Right)),
            "{}",
            pair.name
        );
        let capped: Vec<u8> = pair.left.iter().map(|p| p / 16).collect();
        assert_eq!(
            check(&pair, &capped, &pair.right),
            Some(FrameFault::LensCapped(Lens::Left)),
            "{}",
            pair.name
        );
        let centre = [0.25, 0.25, 0.75, 0.75];
        for (left, right) in [
            (glare(&pair, &pair.left, centre, 1.0), pair.right.clone()),
            (pair.left.clone(), glare(&pair, &pair.right, centre, 1.0)),
            (glare(&pair, &pair.left, centre, 1.0), glare(&pair, &pair.right, centre, 1.0)),
        ] {
            assert_eq!(check(&pair, &left, &right), Some(FrameFault::Glare), "{}", pair.name);
        }
        let whole = [0.0, 0.0, 1.0, 1.0];
        let (left, right) = (glare(&pair, &pair.left, whole, 1.0), glare(&pair, &pair.right, whole, 1.0));
        assert_eq!(check(&pair, &left, &right), Some(FrameFault::Saturated), "{}", pair.name);
        let dimmed: Vec<u8> = pair.right.iter().map(|&p| (f64::from(p) * 0.4) as u8).collect();
        assert_eq!(check(&pair, &pair.left, &dimmed), Some(FrameFault::BrightnessMismatch), "{}", pair.name);
    }
}
