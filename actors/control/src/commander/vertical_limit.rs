//! What the rangefinders hold back this flight (`vertical` has the rules): the sensors' newest
//! readings, a landing moving off an obstacle's top, and, for the status, what limits the
//! vehicle vertically this update.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    NavState, RangefinderSample, SetpointTarget, VerticalLimitKind, VerticalLimitStatus,
};

use super::vertical::{self, LandingSearch, Rangefinders, VerticalParams};

/// A vehicle within this of the ceiling the upward rangefinder sets (m) is held by it.
const AT_CEILING_M: f64 = 0.5;

/// The rangefinders, the landing search and the vertical limit reported.
#[derive(Debug, Default)]
pub(crate) struct VerticalLimit {
    /// The up- and downward rangefinders.
    rangefinders: Rangefinders,
    /// A landing moving off an obstacle's top; reset by a mode change and on disarming.
    pub landing_search: LandingSearch,
    /// What the rangefinders hold back this update, for the status.
    status: Option<VerticalLimitStatus>,
    /// A mode lowered its climb's goal to the ceiling this update.
    ceiling_held: bool,
}

impl VerticalLimit {
    /// A reading of the up- or downward rangefinder; a bad one is refused with the reason, the
    /// last good one stays until it times out.
    pub fn on_sample(&mut self, sample: &RangefinderSample) -> Result<(), String> {
        self.rangefinders.on_sample(sample)
    }

    pub fn rangefinders(&self) -> &Rangefinders {
        &self.rangefinders
    }

    /// What holds the vehicle back vertically, as last reported.
    pub fn status(&self) -> Option<VerticalLimitStatus> {
        self.status
    }

    /// A new mode, or disarmed: no landing search under way.
    pub fn reset_landing_search(&mut self) {
        self.landing_search = LandingSearch::default();
    }

    /// The highest the vehicle may climb to now (NED down, m), if something is overhead.
    pub fn ceiling_down_m(&self, now: Time, nav: &NavState, p: &VerticalParams) -> Option<f64> {
        self.rangefinders.ceiling_down_m(now, nav, p)
    }

    /// `down` (NED, m), or the steady ceiling the upward rangefinder sets if that is lower
    /// down: where a climb towards `down` ends.
    pub fn under_steady_ceiling(&self, now: Time, nav: &NavState, down: f64, p: &VerticalParams) -> f64 {
        let ceiling = self.rangefinders.steady_ceiling_down_m(now, nav, p);
        ceiling.map_or(down, |c| down.max(c))
    }

    /// `down` (NED, m), or the ceiling the upward rangefinder sets if that is lower down (which
    /// the status then reports).
    pub fn under_ceiling(&mut self, now: Time, nav: &NavState, down: f64, p: &VerticalParams) -> f64 {
        match self.ceiling_down_m(now, nav, p) {
            Some(ceiling) if ceiling > down => {
                self.ceiling_held = true;
                ceiling
            }
            _ => down,
        }
    }

    /// A new update: no mode has lowered its goal yet.
    pub fn begin_update(&mut self) {
        self.ceiling_held = false;
    }

    /// Keeps `target` below what the upward rangefinder sees at `nav`, and notes for the status
    /// what holds the vehicle back vertically this update.
    pub fn hold_below_ceiling(
        &mut self,
        now: Time,
        nav: Option<&NavState>,
        target: &mut SetpointTarget,
        p: &VerticalParams,
    ) {
        // Held by the ceiling last update: a wider band keeps the status from flickering.
        let band_m = match self.status {
            Some(VerticalLimitStatus { kind: VerticalLimitKind::Overhead, .. }) => 2.0 * AT_CEILING_M,
            _ => AT_CEILING_M,
        };
        self.status = self
            .landing_search
            .below_m
            .filter(|_| self.landing_search.searching())
            .map(|distance_m| VerticalLimitStatus { kind: VerticalLimitKind::ObstacleBelow, distance_m });
        let Some(nav) = nav else { return };
        let Some(ceiling) = self.ceiling_down_m(now, nav, p) else { return };
        let down = nav.position_ned_m[2];
        // Held: the setpoint was lowered, a mode lowered its goal (or kept the vehicle on the
        // ground), or the vehicle sits at the ceiling not asked to descend (a hold there would
        // otherwise flicker in and out of the status).
        let held = match target {
            SetpointTarget::Trajectory(sp) => {
                let at_ceiling = down - ceiling < band_m && sp.velocity_ned_m_s[2].is_none_or(|v| v <= 0.0);
                vertical::hold_below(sp, down, ceiling, p) || at_ceiling
            }
            _ => false,
        };
        if held || self.ceiling_held {
            let distance_m = down - ceiling + p.margin_m;
            self.status = Some(VerticalLimitStatus { kind: VerticalLimitKind::Overhead, distance_m });
        }
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::{RangefinderOrientation, TrajectorySetpoint};

    use super::*;
    use crate::commander::tests::nav;

    fn up(t: Time, distance_m: f64) -> RangefinderSample {
        let orientation = RangefinderOrientation::Up;
        RangefinderSample {
            time: t,
            orientation,
            distance_m: Some(distance_m),
            min_range_m: 0.1,
            max_range_m: 12.0,
        }
    }

    #[test]
    fn without_a_ceiling_nothing_is_held_or_reported() {
        let (mut v, p) = (VerticalLimit::default(), VerticalParams::default());
        let n = nav(Time(1000), -5.0, true);
        let mut target = SetpointTarget::Trajectory(TrajectorySetpoint {
            position_ned_m: [None, None, Some(-20.0)],
            ..TrajectorySetpoint::default()
        });
        let before = target;
        v.begin_update();
        v.hold_below_ceiling(Time(1000), Some(&n), &mut target, &p);
        assert_eq!(target, before);
        assert_eq!(v.status(), None);
        assert_eq!(v.under_ceiling(Time(1000), &n, -20.0, &p), -20.0);
    }

    #[test]
    fn a_climb_under_a_ceiling_is_lowered_and_reported_overhead() {
        let (mut v, p) = (VerticalLimit::default(), VerticalParams::default());
        let t = Time(1000);
        v.on_sample(&up(t, 6.0)).expect("a good reading");
        let n = nav(t, -5.0, true);
        let ceiling = v.ceiling_down_m(t, &n, &p).expect("overhead");
        assert!((ceiling - (-11.0 + p.margin_m)).abs() < 1e-9, "{ceiling}");
        let mut target = SetpointTarget::Trajectory(TrajectorySetpoint {
            position_ned_m: [None, None, Some(-20.0)],
            ..TrajectorySetpoint::default()
        });
        v.begin_update();
        v.hold_below_ceiling(t, Some(&n), &mut target, &p);
        let SetpointTarget::Trajectory(sp) = target else { panic!("a trajectory") };
        assert_eq!(sp.position_ned_m[2], Some(ceiling), "lowered to the ceiling");
        let status = v.status().expect("reported");
        assert_eq!(status.kind, VerticalLimitKind::Overhead);
        assert!((status.distance_m - 6.0).abs() < 1e-9, "{}", status.distance_m);
        assert_eq!(v.under_ceiling(t, &n, -20.0, &p), ceiling);
    }
}
