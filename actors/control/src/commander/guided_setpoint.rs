//! How GUIDED flies a SET_POSITION_TARGET_* or SET_ATTITUDE_TARGET: the target's axes as the
//! trajectory's, its yaw or yaw rate as the heading, and an attitude as ALT_HOLD flies the
//! sticks (a tilt is a horizontal acceleration g·tan(tilt), the climb a vertical velocity).

use std::f64::consts::PI;

use kestrel_proto::messages::{AttitudeTarget, NavState, PositionTarget, SetpointTarget, TrajectorySetpoint};
use kestrel_proto::units::GRAVITY_M_S2;
use nalgebra::{Quaternion, UnitQuaternion};

use super::{Commander, heading};

/// Largest tilt a SET_ATTITUDE_TARGET may ask for (rad): the lean ArduCopter's `ANGLE_MAX`
/// allows by default (30°), beyond which it limits the attitude controller's demand.
const MAX_ATTITUDE_TILT_RAD: f64 = 30.0 * PI / 180.0;

impl Commander {
    /// The heading to fly: a yaw rate (limited to `yaw_rate_deg_s`) turns the held heading by
    /// rate·dt; otherwise the held heading (set to the target's yaw when it came: `commands`).
    fn guided_heading(&mut self, nav: &NavState, rate_rad_s: Option<f64>, dt_s: f64) -> (f64, f64) {
        let limit = self.params.yaw_rate_deg_s.to_radians();
        let rate = rate_rad_s.map_or(0.0, |r| r.clamp(-limit, limit));
        let held = self.latched.hold.yaw_rad.unwrap_or_else(|| heading(nav));
        let yaw = (held + rate * dt_s + PI).rem_euclid(2.0 * PI) - PI;
        self.latched.hold.yaw_rad = Some(yaw);
        (yaw, rate)
    }

    /// A position/velocity/acceleration target: each present part is the trajectory's (a
    /// velocity with a position is the position loop's feed-forward). Held by
    /// `tests::guided::a_position_target_flies_its_parts_and_turns_at_its_yaw_rate`.
    pub(super) fn fly_position_target(
        &mut self,
        nav: &NavState,
        t: &PositionTarget,
        dt_s: f64,
    ) -> SetpointTarget {
        let (yaw, rate) = self.guided_heading(nav, t.yaw_rate_rad_s, dt_s);
        let axes = |v: Option<[f64; 3]>| v.map_or([None; 3], |v| v.map(Some));
        SetpointTarget::Trajectory(TrajectorySetpoint {
            position_ned_m: axes(t.position_ned_m),
            velocity_ned_m_s: axes(t.velocity_ned_m_s),
            acceleration_ned_m_s2: t.acceleration_ned_m_s2.unwrap_or([0.0; 3]),
            yaw_rad: Some(yaw),
            yaw_rate_rad_s: rate,
            max_horizontal_speed_m_s: t.speed_m_s,
            ..TrajectorySetpoint::default()
        })
    }

    /// An attitude target: its roll and pitch (at most `MAX_ATTITUDE_TILT_RAD`) as a horizontal
    /// acceleration, its heading as the yaw, and its climb share times `stick_climb_m_s` as the
    /// vertical velocity (0 holding the height reached), as ArduCopter's `angle_control_run`
    /// flies the default `GUID_OPTIONS`. Held by
    /// `tests::guided::an_attitude_target_tilts_towards_its_lean_and_climbs`.
    pub(super) fn fly_attitude_target(
        &mut self,
        nav: &NavState,
        t: &AttitudeTarget,
        dt_s: f64,
    ) -> SetpointTarget {
        let [w, x, y, z] = t.attitude;
        let (roll, pitch, yaw_q) =
            UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)).euler_angles();
        self.latched.hold.yaw_rad = Some(yaw_q);
        let (yaw, rate) = self.guided_heading(nav, Some(t.yaw_rate_rad_s), dt_s);
        let tilt = |a: f64| GRAVITY_M_S2 * a.clamp(-MAX_ATTITUDE_TILT_RAD, MAX_ATTITUDE_TILT_RAD).tan();
        // Nose down (negative pitch) accelerates forward; right roll accelerates right.
        let (fwd, right) = (tilt(-pitch), tilt(roll));
        let (sin, cos) = yaw.sin_cos();
        let (pz, vz) = if t.climb == 0.0 {
            (Some(*self.latched.hold.down_m.get_or_insert(nav.position_ned_m[2])), None)
        } else {
            self.latched.hold.down_m = None;
            (None, Some(-t.climb.clamp(-1.0, 1.0) * self.params.stick_climb_m_s))
        };
        SetpointTarget::Trajectory(TrajectorySetpoint {
            position_ned_m: [None, None, pz],
            velocity_ned_m_s: [None, None, vz],
            acceleration_ned_m_s2: [fwd * cos - right * sin, fwd * sin + right * cos, 0.0],
            yaw_rad: Some(yaw),
            yaw_rate_rad_s: rate,
            ..TrajectorySetpoint::default()
        })
    }
}
