//! Is the camera still seeing? Two faults a stereo camera shows while it keeps delivering
//! frames on time, so that the stale-frame checks downstream never fire:
//! * **dark**: a lens cap, a covered or dead sensor, night. Nearly every pixel of the left
//!   image is black. Matching such a frame gives no disparity, which the avoider would read as
//!   "nothing seen", not as "nothing there".
//! * **frozen**: a driver or capture pipeline that hands out the same buffer again. Every pixel
//!   of both images equals the previous frame's while the vehicle moves or turns, which no
//!   working camera does: its own noise alone changes some pixels, and motion changes many.
//!   Standing still in front of a static scene a noiseless (simulated) camera repeats its
//!   pixels exactly, so without motion the check never calls a frame frozen.
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
    /// A frame whose left image has at least this share of black pixels is dark (0..=1).
    pub dark_share: f64,
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
        if !(self.dark_share > 0.0 && self.dark_share <= 1.0) {
            return bad("dark_share", self.dark_share, "a share in (0, 1]");
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

/// What is wrong with a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameFault {
    Dark,
    Frozen,
}

impl FrameFault {
    /// For logs and STATUSTEXT: what the camera does.
    pub fn describe(self) -> &'static str {
        match self {
            FrameFault::Dark => "frames black",
            FrameFault::Frozen => "frames frozen",
        }
    }
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
        let dark_level = self.params.dark_level;
        let black = left.iter().filter(|&&p| p <= dark_level).count();
        if !left.is_empty() && black as f64 >= self.params.dark_share * left.len() as f64 {
            return Some(FrameFault::Dark);
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
        assert!(d().validate().is_ok());
    }
}
