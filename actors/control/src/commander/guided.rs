//! What a ground station points the vehicle at: GUIDED's position or velocity target (and
//! when it last came), the take-off height, and where the nose points in GUIDED and AUTO
//! (CONDITION_YAW, DO_SET_ROI_LOCATION / DO_SET_ROI_NONE). A mode change drops the target and
//! the nose's aim; the take-off height is the last one asked for.

use kestrel_proto::Time;
use kestrel_proto::messages::{AttitudeTarget, NavState, PositionTarget};

use super::arming::{Refusal, refuse};

/// Where GUIDED and AUTO point the nose instead of holding the heading they have.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum YawTarget {
    /// A heading (rad, from north, clockwise).
    Heading(f64),
    /// A region of interest, NED from the estimator's origin (m).
    Towards([f64; 3]),
}

/// GUIDED's target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum GuidedTarget {
    Hold,
    /// NED from the estimator's origin (m).
    Position([f64; 3]),
    /// NED (m/s).
    Velocity([f64; 3]),
    /// SET_POSITION_TARGET_*: one of ArduCopter's accepted position/velocity/acceleration
    /// combinations with its yaw (flown by `guided_setpoint`).
    Setpoint(PositionTarget),
    /// SET_ATTITUDE_TARGET (flown by `guided_setpoint`).
    Attitude(AttitudeTarget),
}

/// GUIDED's target, the nose's aim and the take-off height.
#[derive(Debug)]
pub(crate) struct Guided {
    target: GuidedTarget,
    /// When the target last came: a velocity stream that stops is held (`guided_timeout_s`).
    at: Option<Time>,
    /// Where the nose points in GUIDED and AUTO; cleared by a mode change and DO_SET_ROI_NONE.
    yaw: Option<YawTarget>,
    /// Height above home TAKEOFF climbs to (m): `takeoff_altitude_m`, or the last
    /// MAV_CMD_NAV_TAKEOFF's.
    takeoff_height_m: f64,
}

impl Guided {
    pub fn new(takeoff_height_m: f64) -> Guided {
        Guided { target: GuidedTarget::Hold, at: None, yaw: None, takeoff_height_m }
    }

    pub fn target(&self) -> GuidedTarget {
        self.target
    }

    /// A new mode: hold, and the nose's aim is dropped.
    pub fn on_mode_change(&mut self) {
        self.target = GuidedTarget::Hold;
        self.yaw = None;
    }

    /// A target checked by the commander, received at `now`. One that carries its own yaw or
    /// yaw rate (or an attitude) replaces CONDITION_YAW's heading and the region of interest,
    /// as ArduCopter's `set_yaw_state` replaces the auto-yaw mode.
    pub fn set_target(&mut self, target: GuidedTarget, now: Time) {
        let own_yaw = match target {
            GuidedTarget::Setpoint(t) => t.yaw_rad.is_some() || t.yaw_rate_rad_s.is_some(),
            GuidedTarget::Attitude(_) => true,
            GuidedTarget::Hold | GuidedTarget::Position(_) | GuidedTarget::Velocity(_) => false,
        };
        if own_yaw {
            self.yaw = None;
        }
        self.target = target;
        self.at = Some(now);
    }

    /// What a stream that stopped leaves after `timeout_s` (ArduCopter's GUID_TIMEOUT, 3 s; PX4's
    /// COM_OF_LOSS_T): a velocity, an acceleration or an attitude is dropped for a hold where the
    /// vehicle is; a position keeps flying to its point, without the velocity, acceleration and
    /// yaw rate that came with it (ArduCopter's `posvelaccel_control_run` zeroes them and turns
    /// the rate yaw into a hold). ArduCopter levels and holds the height on an attitude timeout
    /// but lets the wind carry it: the hold keeps the place as well. True when the target was
    /// cut now. Held by `tests::a_stopped_stream_keeps_only_a_position`.
    pub fn drop_stale_stream(&mut self, now: Time, timeout_s: f64) -> bool {
        let streamed = match self.target {
            GuidedTarget::Velocity(_) | GuidedTarget::Attitude(_) => true,
            GuidedTarget::Setpoint(t) => {
                t.position_ned_m.is_none()
                    || t.velocity_ned_m_s.is_some()
                    || t.acceleration_ned_m_s2.is_some()
                    || t.yaw_rate_rad_s.is_some()
            }
            GuidedTarget::Hold | GuidedTarget::Position(_) => false,
        };
        let stale = streamed && self.at.is_some_and(|t| now.saturating_since(t).as_secs_f64() > timeout_s);
        if stale {
            self.target = match self.target {
                GuidedTarget::Setpoint(PositionTarget { position_ned_m: Some(p), yaw_rad, .. }) => {
                    GuidedTarget::Setpoint(PositionTarget {
                        position_ned_m: Some(p),
                        yaw_rad,
                        ..Default::default()
                    })
                }
                _ => GuidedTarget::Hold,
            };
        }
        stale
    }

    /// A position target with a velocity moves along it (m, over `dt_s` s), as ArduCopter's
    /// position controller advances a position-velocity target between messages.
    pub fn advance(&mut self, dt_s: f64) {
        if let GuidedTarget::Setpoint(PositionTarget {
            position_ned_m: Some(p),
            velocity_ned_m_s: Some(v),
            ..
        }) = &mut self.target
        {
            for (p, v) in p.iter_mut().zip(v.iter()) {
                *p += v * dt_s;
            }
        }
    }

    pub fn takeoff_height_m(&self) -> f64 {
        self.takeoff_height_m
    }

    pub fn set_takeoff_height_m(&mut self, height_m: f64) {
        self.takeoff_height_m = height_m;
    }

    /// CONDITION_YAW: one finite absolute heading, or a turn from `current_rad` (degrees in).
    pub fn set_yaw(
        &mut self,
        heading_deg: Option<f64>,
        relative_deg: Option<f64>,
        current_rad: f64,
    ) -> Result<(), Refusal> {
        let yaw = match (heading_deg, relative_deg) {
            (Some(h), None) if h.is_finite() => h.to_radians(),
            (None, Some(r)) if r.is_finite() => current_rad + r.to_radians(),
            _ => return refuse("yaw refused: give one finite heading or turn"),
        };
        self.yaw = Some(YawTarget::Heading(yaw));
        Ok(())
    }

    /// DO_SET_ROI_LOCATION (NED, m), or DO_SET_ROI_NONE for `None`.
    pub fn set_region_of_interest(&mut self, position_ned_m: Option<[f64; 3]>) -> Result<(), Refusal> {
        match position_ned_m {
            Some(p) if p.iter().all(|v| v.is_finite()) => self.yaw = Some(YawTarget::Towards(p)),
            Some(_) => return refuse("region of interest is not finite"),
            None => self.yaw = None,
        }
        Ok(())
    }

    /// The heading CONDITION_YAW or DO_SET_ROI_LOCATION asks for (rad), if any: a fixed one, or
    /// towards the region of interest (`held_rad` while the vehicle is within a metre of it).
    pub fn aimed_yaw(&self, nav: &NavState, held_rad: Option<f64>) -> Option<f64> {
        match self.yaw? {
            YawTarget::Heading(yaw_rad) => Some(yaw_rad),
            YawTarget::Towards(roi) => {
                let (north, east) = (roi[0] - nav.position_ned_m[0], roi[1] - nav.position_ned_m[1]);
                (north.hypot(east) > 1.0).then(|| east.atan2(north)).or(held_rad)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commander::tests::nav;

    #[test]
    fn a_velocity_is_dropped_for_a_hold_once_not_repeated_within_the_timeout() {
        let mut g = Guided::new(2.5);
        g.set_target(GuidedTarget::Velocity([1.0, 0.0, 0.0]), Time::from_secs_f64(1.0));
        assert!(!g.drop_stale_stream(Time::from_secs_f64(3.0), 3.0));
        assert!(g.drop_stale_stream(Time::from_secs_f64(4.5), 3.0));
        assert_eq!(g.target(), GuidedTarget::Hold);
        g.set_target(GuidedTarget::Position([5.0, 0.0, -3.0]), Time::from_secs_f64(5.0));
        assert!(!g.drop_stale_stream(Time::from_secs_f64(60.0), 3.0), "a position is kept");
    }

    #[test]
    fn a_stopped_stream_keeps_only_a_position() {
        let mut g = Guided::new(2.5);
        let t = |s: f64| Time::from_secs_f64(s);
        let full = PositionTarget {
            position_ned_m: Some([5.0, 0.0, -3.0]),
            velocity_ned_m_s: Some([1.0, 0.0, 0.0]),
            acceleration_ned_m_s2: Some([0.5, 0.0, 0.0]),
            yaw_rad: Some(1.0),
            yaw_rate_rad_s: Some(0.2),
            speed_m_s: None,
        };
        g.set_target(GuidedTarget::Setpoint(full), t(1.0));
        g.advance(0.5);
        assert!(!g.drop_stale_stream(t(4.0), 3.0), "within the timeout");
        assert!(g.drop_stale_stream(t(4.01), 3.0));
        let kept = PositionTarget {
            position_ned_m: Some([5.5, 0.0, -3.0]),
            yaw_rad: Some(1.0),
            ..Default::default()
        };
        assert_eq!(g.target(), GuidedTarget::Setpoint(kept), "moved along its velocity, then only the point");
        assert!(!g.drop_stale_stream(t(60.0), 3.0), "a bare position is kept for ever");
        let accel = PositionTarget { acceleration_ned_m_s2: Some([1.0, 0.0, 0.0]), ..Default::default() };
        g.set_target(GuidedTarget::Setpoint(accel), t(61.0));
        assert!(g.drop_stale_stream(t(64.5), 3.0));
        assert_eq!(g.target(), GuidedTarget::Hold, "an acceleration alone is not flown on");
    }

    #[test]
    fn a_target_with_its_own_yaw_replaces_the_region_of_interest() {
        let mut g = Guided::new(2.5);
        let n = nav(Time(1000), -5.0, true);
        g.set_region_of_interest(Some([0.0, 10.0, 0.0])).expect("east");
        g.set_target(GuidedTarget::Velocity([1.0, 0.0, 0.0]), Time(2000));
        assert!(g.aimed_yaw(&n, None).is_some(), "a velocity alone keeps the aim");
        let turn = PositionTarget {
            velocity_ned_m_s: Some([1.0, 0.0, 0.0]),
            yaw_rate_rad_s: Some(0.3),
            ..Default::default()
        };
        g.set_target(GuidedTarget::Setpoint(turn), Time(3000));
        assert_eq!(g.aimed_yaw(&n, None), None);
    }

    #[test]
    fn yaw_takes_one_finite_heading_or_turn_and_a_mode_change_drops_it() {
        let mut g = Guided::new(2.5);
        let n = nav(Time(1000), -5.0, true);
        assert!(g.set_yaw(Some(90.0), Some(10.0), 0.0).is_err(), "both");
        assert!(g.set_yaw(Some(f64::NAN), None, 0.0).is_err());
        assert!(g.set_yaw(None, None, 0.0).is_err());
        g.set_yaw(None, Some(90.0), 0.5).expect("a turn");
        let aimed = g.aimed_yaw(&n, None).expect("aimed");
        assert!((aimed - (0.5 + std::f64::consts::FRAC_PI_2)).abs() < 1e-12);
        g.on_mode_change();
        assert_eq!(g.aimed_yaw(&n, Some(1.0)), None);
    }

    #[test]
    fn a_region_of_interest_is_faced_until_within_a_metre_of_it() {
        let mut g = Guided::new(2.5);
        assert!(g.set_region_of_interest(Some([f64::INFINITY, 0.0, 0.0])).is_err());
        g.set_region_of_interest(Some([0.0, 10.0, 0.0])).expect("east");
        let n = nav(Time(1000), -5.0, true);
        let east = g.aimed_yaw(&n, None).expect("aimed");
        assert!((east - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        g.set_region_of_interest(Some([0.5, 0.0, 0.0])).expect("near");
        assert_eq!(g.aimed_yaw(&n, Some(0.3)), Some(0.3), "within a metre: the held heading");
        g.set_region_of_interest(None).expect("none");
        assert_eq!(g.aimed_yaw(&n, Some(0.3)), None);
    }
}
