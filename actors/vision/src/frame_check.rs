//! Is the camera still seeing? Faults a stereo camera shows while it keeps delivering frames on
//! time, so that the stale-frame checks downstream never fire. Each has a name a ground station
//! shows ([`FrameFault::describe`]):
//! * **`camera_blind: dark`**: both images nearly all black (night, a dead sensor, both lenses
//!   covered). Matching gives no disparity, which the avoider would read as "nothing seen", not
//!   "nothing there".
//! * **`lens_capped: left` / `right`**: one image nearly all black and the other not: a cap or a
//!   finger on one lens. The other lens alone gives no depth.
//! * **`camera_blind: saturated`**: nearly every pixel of an image white (the sun in the lens,
//!   thesis §4.2.4; an exposure stuck open). A saturated pixel carries no texture to match.
//! * **`camera_blind: glare`**: the centre region (the middle third of rows and columns, the
//!   flight path of the avoider's 3×3 grid) mostly saturated in either image. Glare over the
//!   path would otherwise read as "no valid pixel ahead" while the rest of the view looks clear.
//! * **`camera_blind: brightness mismatch`**: the two images' mean grey levels differ by more than
//!   a factor [`FrameCheckParams::mismatch_ratio`] (a half-covered lens, glare on one lens, one
//!   exposure control stuck). SGBM matches grey levels, so such a pair gives wrong depth.
//! * **`camera_blind: frozen`**: a driver or capture pipeline that hands out the same buffer
//!   again. Every pixel of both images equals the previous frame's while the vehicle moves or
//!   turns, which no working camera does: its own noise alone changes some pixels, and motion
//!   changes many. Standing still in front of a static scene a noiseless (simulated) camera
//!   repeats its pixels exactly, so without motion the check never calls a frame frozen.
//!
//! The thresholds' defaults were measured on the real pairs in `actors/vision/tests/data/`
//! (Middlebury cones, teddy, reindeer; OpenCV's 13 calibration pairs) and the simulator's
//! renders; `tests/frame_check.rs` of this crate runs the check over every real pair (no fault)
//! and over the same pairs with each fault applied (each named).
//!
//! A faulty frame gives no depth grid: the avoider's input goes stale, and the commander slows,
//! holds and after `avoidance_lost_s` lands, as when frames stop.

use kestrel_proto::Time;
use kestrel_proto::messages::StereoFrame;
use serde::Deserialize;

use crate::error::VisionError;

/// The checks' thresholds (the `frame_check` table of the stereo actor's parameters).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct FrameCheckParams {
    /// A pixel at or below this grey level is black.
    pub dark_level: u8,
    /// An image with at least this share of black pixels is dark (0..=1). The real pairs have at
    /// most 12.8 % (OpenCV pair 11's right image).
    pub dark_share: f64,
    /// A pixel at or above this grey level is saturated (white, no texture left). The simulator's
    /// sky is 200.
    pub saturated_level: u8,
    /// An image with at least this share of saturated pixels is saturated (0..=1). The real pairs
    /// have at most 10.9 % (OpenCV pair 5's left image: a white board under a lamp).
    pub saturated_share: f64,
    /// A centre region (middle third of rows and of columns) of either image with at least this
    /// share of saturated pixels is under glare (0..=1). The real pairs' centre regions have at
    /// most 34.4 % (OpenCV pair 5's left image), so 0.6 leaves a margin of 1.7×.
    pub glare_share: f64,
    /// The images' mean grey levels (plus one, so black is defined) differ by more than this
    /// factor: a brightness mismatch (> 1). The real pairs differ by at most a factor 1.085
    /// (OpenCV pair 7); a lens half covered or one exposure stuck differs by 2 or more.
    pub mismatch_ratio: f64,
    /// Frames identical for this long while the vehicle moves are frozen (s).
    pub frozen_after_s: f64,
    /// Moving: faster than this (m/s)...
    pub moving_m_s: f64,
    /// ...or turning faster than this (rad/s).
    pub turning_rad_s: f64,
}

impl Default for FrameCheckParams {
    fn default() -> FrameCheckParams {
        FrameCheckParams {
            dark_level: 16,
            dark_share: 0.99,
            saturated_level: 250,
            saturated_share: 0.9,
            glare_share: 0.6,
            mismatch_ratio: 1.6,
            frozen_after_s: 0.5,
            moving_m_s: 0.3,
            turning_rad_s: 0.2,
        }
    }
}

impl FrameCheckParams {
    /// The first parameter out of its range, named.
    pub fn validate(&self) -> Result<(), VisionError> {
        let bad = |field: &str, value: f64, range: &str| {
            Err(VisionError::Params(format!("frame_check.{field} = {value}: expected {range}")))
        };
        for (field, value) in [
            ("dark_share", self.dark_share),
            ("saturated_share", self.saturated_share),
            ("glare_share", self.glare_share),
        ] {
            if !(value > 0.0 && value <= 1.0) {
                return bad(field, value, "a share in (0, 1]");
            }
        }
        if self.saturated_level <= self.dark_level {
            return bad("saturated_level", f64::from(self.saturated_level), "a grey level above dark_level");
        }
        if !(self.mismatch_ratio.is_finite() && self.mismatch_ratio > 1.0) {
            return bad("mismatch_ratio", self.mismatch_ratio, "a finite factor above 1");
        }
        for (field, value) in [
            ("frozen_after_s", self.frozen_after_s),
            ("moving_m_s", self.moving_m_s),
            ("turning_rad_s", self.turning_rad_s),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return bad(field, value, "a finite value above 0");
            }
        }
        Ok(())
    }
}

/// One lens of the pair.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lens {
    Left,
    Right,
}

/// What is wrong with a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameFault {
    /// Both images black.
    Dark,
    /// One image black, the other not.
    LensCapped(Lens),
    /// An image (nearly) all white.
    Saturated,
    /// The centre region of an image mostly white.
    Glare,
    /// The two images' brightness too far apart.
    BrightnessMismatch,
    /// The same pixels again while moving.
    Frozen,
}

impl FrameFault {
    /// For logs, `sensor_health` and STATUSTEXT: the fault's name and reason.
    pub fn describe(self) -> &'static str {
        match self {
            FrameFault::Dark => "camera_blind: dark",
            FrameFault::LensCapped(Lens::Left) => "lens_capped: left",
            FrameFault::LensCapped(Lens::Right) => "lens_capped: right",
            FrameFault::Saturated => "camera_blind: saturated",
            FrameFault::Glare => "camera_blind: glare",
            FrameFault::BrightnessMismatch => "camera_blind: brightness mismatch",
            FrameFault::Frozen => "camera_blind: frozen",
        }
    }
}

/// The brightness figures of one image the checks read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageStats {
    /// Share of pixels at or below `dark_level` (0..1).
    pub dark_share: f64,
    /// Share of pixels at or above `saturated_level` (0..1).
    pub saturated_share: f64,
    /// Share of the centre region's pixels at or above `saturated_level` (0..1).
    pub centre_saturated_share: f64,
    /// Mean grey level (0..255).
    pub mean: f64,
}

impl ImageStats {
    /// The figures of a `width`×`height` grey image (row-major); all 0 for an empty image.
    pub fn measure(pixels: &[u8], width: usize, height: usize, params: &FrameCheckParams) -> ImageStats {
        if pixels.is_empty() || width == 0 || pixels.len() != width * height {
            return ImageStats {
                dark_share: 0.0,
                saturated_share: 0.0,
                centre_saturated_share: 0.0,
                mean: 0.0,
            };
        }
        let (dark_level, saturated_level) = (params.dark_level, params.saturated_level);
        let (mut dark, mut saturated, mut sum) = (0usize, 0usize, 0u64);
        for &p in pixels {
            dark += usize::from(p <= dark_level);
            saturated += usize::from(p >= saturated_level);
            sum += u64::from(p);
        }
        // The avoider's 3×3 grid splits rows and columns into thirds the same way.
        let (x0, x1, y0, y1) = (width / 3, 2 * width / 3, height / 3, 2 * height / 3);
        let mut centre_saturated = 0usize;
        for row in pixels.chunks_exact(width).take(y1).skip(y0) {
            centre_saturated += row[x0..x1].iter().filter(|&&p| p >= saturated_level).count();
        }
        let n = pixels.len() as f64;
        let centre_n = ((x1 - x0) * (y1 - y0)).max(1) as f64;
        ImageStats {
            dark_share: dark as f64 / n,
            saturated_share: saturated as f64 / n,
            centre_saturated_share: centre_saturated as f64 / centre_n,
            mean: sum as f64 / n,
        }
    }
}

/// The verdict on a pair from its two images' figures, frozen aside: the first fault in the
/// order of [`FrameFault`] (a capped lens is also a brightness mismatch; it is named as the
/// more specific fault).
pub fn judge(left: &ImageStats, right: &ImageStats, params: &FrameCheckParams) -> Option<FrameFault> {
    let dark = |s: &ImageStats| s.dark_share >= params.dark_share;
    match (dark(left), dark(right)) {
        (true, true) => return Some(FrameFault::Dark),
        (true, false) => return Some(FrameFault::LensCapped(Lens::Left)),
        (false, true) => return Some(FrameFault::LensCapped(Lens::Right)),
        (false, false) => {}
    }
    if left.saturated_share >= params.saturated_share || right.saturated_share >= params.saturated_share {
        return Some(FrameFault::Saturated);
    }
    if left.centre_saturated_share >= params.glare_share || right.centre_saturated_share >= params.glare_share
    {
        return Some(FrameFault::Glare);
    }
    let (l, r) = (left.mean + 1.0, right.mean + 1.0);
    if l.max(r) / l.min(r) > params.mismatch_ratio {
        return Some(FrameFault::BrightnessMismatch);
    }
    None
}

/// The checks' state: the previous frame's pixels and how long they have repeated in motion.
#[derive(Debug, Default)]
pub struct FrameCheck {
    params: FrameCheckParams,
    /// Left then right pixels of the previous frame; sized once, on the first frame.
    previous: Vec<u8>,
    /// Capture time of the first frame of the current run of identical ones that came while
    /// the vehicle moved.
    repeating_in_motion_since: Option<Time>,
    /// The newest motion heard: moving or turning.
    moving: bool,
}

impl FrameCheck {
    pub fn new(params: FrameCheckParams) -> FrameCheck {
        FrameCheck { params, ..FrameCheck::default() }
    }

    /// The vehicle's newest velocity (NED, m/s) and body rate (FRD, rad/s), from its NavState.
    pub fn on_motion(&mut self, velocity_m_s: [f64; 3], rate_rad_s: [f64; 3]) {
        let norm = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        self.moving =
            norm(velocity_m_s) > self.params.moving_m_s || norm(rate_rad_s) > self.params.turning_rad_s;
    }

    /// Checks `frame`; `None` when it looks like a working camera's.
    pub fn check(&mut self, frame: &StereoFrame) -> Option<FrameFault> {
        let (left, right) = (frame.left(), frame.right());
        let same = self.previous.len() == left.len() + right.len()
            && self.previous[..left.len()] == *left
            && self.previous[left.len()..] == *right;
        if !same {
            self.previous.clear();
            self.previous.extend_from_slice(left);
            self.previous.extend_from_slice(right);
            self.repeating_in_motion_since = None;
        } else if self.moving {
            self.repeating_in_motion_since.get_or_insert(frame.time);
        }
        let (width, height) = (frame.width as usize, frame.height as usize);
        let left_stats = ImageStats::measure(left, width, height, &self.params);
        let right_stats = ImageStats::measure(right, width, height, &self.params);
        if let Some(fault) = judge(&left_stats, &right_stats, &self.params) {
            return Some(fault);
        }
        let frozen_for_s =
            self.repeating_in_motion_since.map(|since| frame.time.as_secs_f64() - since.as_secs_f64());
        frozen_for_s.filter(|&s| s >= self.params.frozen_after_s).map(|_| FrameFault::Frozen)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(seq: u64, t_s: f64, fill: impl Fn(usize) -> u8) -> StereoFrame {
        let (w, h) = (32u32, 24u32);
        let image: Vec<u8> = (0..(w * h) as usize).map(&fill).collect();
        StereoFrame::new(Time::from_micros((t_s * 1e6) as u64), seq, w, h, image.clone(), image)
            .expect("sizes match")
    }

    fn textured(k: usize) -> impl Fn(usize) -> u8 {
        move |i| ((i * 37 + k * 11) % 200 + 30) as u8
    }

    #[test]
    fn a_black_frame_is_dark_and_a_dim_textured_one_is_not() {
        let mut check = FrameCheck::new(FrameCheckParams::default());
        assert_eq!(check.check(&frame(0, 0.0, |_| 3)), Some(FrameFault::Dark));
        // Half a percent of the pixels lit is still a lens cap's leak.
        assert_eq!(
            check.check(&frame(1, 0.1, |i| if i % 200 == 0 { 200 } else { 0 })),
            Some(FrameFault::Dark)
        );
        assert_eq!(check.check(&frame(2, 0.2, |i| if i % 50 == 0 { 200 } else { 0 })), None, "2 % lit");
        assert_eq!(check.check(&frame(3, 0.3, |i| (i % 40) as u8)), None, "dim but textured");
    }

    fn pair(fill_left: impl Fn(usize) -> u8, fill_right: impl Fn(usize) -> u8) -> StereoFrame {
        let (w, h) = (30u32, 24u32);
        let left: Vec<u8> = (0..(w * h) as usize).map(fill_left).collect();
        let right: Vec<u8> = (0..(w * h) as usize).map(fill_right).collect();
        StereoFrame::new(Time::ZERO, 0, w, h, left, right).expect("sizes match")
    }

    #[test]
    fn one_black_lens_is_capped_and_named_by_side() {
        let check = |f: StereoFrame| FrameCheck::new(FrameCheckParams::default()).check(&f);
        assert_eq!(check(pair(textured(0), |_| 2)), Some(FrameFault::LensCapped(Lens::Right)));
        assert_eq!(check(pair(|_| 2, textured(0))), Some(FrameFault::LensCapped(Lens::Left)));
        assert_eq!(check(pair(|_| 2, |_| 0)), Some(FrameFault::Dark));
    }

    #[test]
    fn white_frames_are_saturated_and_a_white_centre_is_glare() {
        let check = |f: StereoFrame| FrameCheck::new(FrameCheckParams::default()).check(&f);
        assert_eq!(check(pair(|_| 255, |_| 255)), Some(FrameFault::Saturated));
        assert_eq!(check(pair(textured(0), |_| 252)), Some(FrameFault::Saturated));
        // 30×24: the centre region is columns 10..20, rows 8..16.
        let centre_white = |i: usize| {
            let (x, y) = (i % 30, i / 30);
            if (10..20).contains(&x) && (8..16).contains(&y) { 255 } else { textured(0)(i) }
        };
        assert_eq!(check(pair(textured(0), centre_white)), Some(FrameFault::Glare));
        // The same white patch off the centre is no glare over the path.
        let corner_white = |i: usize| if i % 30 < 10 && i / 30 < 8 { 255 } else { textured(0)(i) };
        assert_eq!(check(pair(corner_white, textured(0))), None);
    }

    #[test]
    fn images_twice_as_bright_as_each_other_mismatch() {
        let check = |f: StereoFrame| FrameCheck::new(FrameCheckParams::default()).check(&f);
        let dim = |i: usize| textured(0)(i) / 2;
        assert_eq!(check(pair(textured(0), dim)), Some(FrameFault::BrightnessMismatch));
        assert_eq!(check(pair(dim, textured(0))), Some(FrameFault::BrightnessMismatch));
        let slightly = |i: usize| textured(0)(i).saturating_sub(10);
        assert_eq!(check(pair(textured(0), slightly)), None);
    }

    proptest::proptest! {
        /// Swapping the lenses swaps the side of a capped lens and changes no other verdict, and
        /// an image between the dark and saturated levels throughout is never blind.
        #[test]
        fn the_verdict_is_symmetric_in_the_lenses(
            left in proptest::collection::vec(proptest::prelude::any::<u8>(), 720),
            right in proptest::collection::vec(proptest::prelude::any::<u8>(), 720),
        ) {
            let params = FrameCheckParams::default();
            let l = ImageStats::measure(&left, 30, 24, &params);
            let r = ImageStats::measure(&right, 30, 24, &params);
            let swapped = |f: Option<FrameFault>| f.map(|f| match f {
                FrameFault::LensCapped(Lens::Left) => FrameFault::LensCapped(Lens::Right),
                FrameFault::LensCapped(Lens::Right) => FrameFault::LensCapped(Lens::Left),
                other => other,
            });
            proptest::prop_assert_eq!(judge(&l, &r, &params), swapped(judge(&r, &l, &params)));
            let mid = |v: &[u8]| v.iter().map(|&p| p.clamp(100, 160)).collect::<Vec<u8>>();
            let (ml, mr) = (mid(&left), mid(&right));
            let (l, r) =
                (ImageStats::measure(&ml, 30, 24, &params), ImageStats::measure(&mr, 30, 24, &params));
            proptest::prop_assert_eq!(judge(&l, &r, &params), None);
        }
    }

    #[test]
    fn repeated_pixels_are_frozen_only_in_motion_and_only_after_frozen_after_s() {
        let mut check = FrameCheck::new(FrameCheckParams::default());
        // Standing still, the same picture for 2 s is a static scene, not a fault.
        for k in 0..40 {
            assert_eq!(check.check(&frame(k, k as f64 * 0.05, textured(0))), None, "still, frame {k}");
        }
        // Moving, the pictures change: fine.
        check.on_motion([1.0, 0.0, 0.0], [0.0; 3]);
        for k in 40..50 {
            assert_eq!(
                check.check(&frame(k, k as f64 * 0.05, textured(k as usize))),
                None,
                "moving, frame {k}"
            );
        }
        // Moving, the picture stops changing: frozen once it has repeated for 0.5 s.
        let verdicts: Vec<_> =
            (50..70).map(|k| check.check(&frame(k, k as f64 * 0.05, textured(49)))).collect();
        let first = verdicts.iter().position(Option::is_some).expect("frozen at last");
        assert_eq!(first, 10, "0.5 s after the first repeat at 20 fps: {verdicts:?}");
        assert!(verdicts[first..].iter().all(|v| *v == Some(FrameFault::Frozen)));
        // A new picture clears it at once.
        assert_eq!(check.check(&frame(70, 3.5, textured(70))), None);
    }

    #[test]
    fn turning_in_place_counts_as_motion() {
        let mut check = FrameCheck::new(FrameCheckParams::default());
        check.on_motion([0.0; 3], [0.0, 0.0, 0.5]);
        let frozen = (0..20).filter_map(|k| check.check(&frame(k, k as f64 * 0.05, textured(0)))).count();
        assert!(frozen > 0, "a turning camera whose pixels never change is frozen");
    }

    #[test]
    fn out_of_range_thresholds_are_refused_by_name() {
        let bad = |p: FrameCheckParams| p.validate().unwrap_err().to_string();
        let d = FrameCheckParams::default;
        assert!(bad(FrameCheckParams { dark_share: 0.0, ..d() }).contains("dark_share"));
        assert!(bad(FrameCheckParams { frozen_after_s: f64::NAN, ..d() }).contains("frozen_after_s"));
        assert!(bad(FrameCheckParams { moving_m_s: -1.0, ..d() }).contains("moving_m_s"));
        assert!(bad(FrameCheckParams { turning_rad_s: f64::INFINITY, ..d() }).contains("turning_rad_s"));
        assert!(bad(FrameCheckParams { glare_share: 1.5, ..d() }).contains("glare_share"));
        assert!(bad(FrameCheckParams { saturated_share: -0.1, ..d() }).contains("saturated_share"));
        assert!(bad(FrameCheckParams { saturated_level: 10, ..d() }).contains("saturated_level"));
        assert!(bad(FrameCheckParams { mismatch_ratio: 1.0, ..d() }).contains("mismatch_ratio"));
        assert!(d().validate().is_ok());
    }
}
