//! CIRCLE (and MAV_CMD_DO_ORBIT): a point moving round a centre at a rate, flown as a position,
//! velocity and acceleration target, the nose on the centre by default.
//!
//! As ArduCopter's `AC_Circle`: entering CIRCLE puts the centre `CIRCLE_RADIUS_M` ahead of the
//! vehicle, so it starts on the circle; the angular rate ramps up from rest at an angular
//! acceleration of `accel / radius` (at least 2°/s²), and is limited so that the tangential speed
//! stays within the horizontal speed limit and `sqrt(accel · radius / 2)` (half the acceleration
//! limit pulls towards the centre). A positive rate turns clockwise seen from above (bearing
//! from north towards east increasing), as `CIRCLE_RATE`. A radius of 0 turns on the spot.
//! Held by `tests::circle` (the reference path in closed form) and the closed-loop flight in
//! `actors/control/tests/modes.rs` (RMS radius error and rate flown).

use kestrel_proto::Time;
use kestrel_proto::messages::{
    FlightMode, LandedState, NavState, OrbitYaw, SetpointTarget, TrajectorySetpoint,
};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::arming::{Refusal, refuse};
use super::{Commander, heading};
use crate::error::{InvalidParam, within};

/// Least angular acceleration of the orbit point (rad/s²): `AC_CIRCLE_ANGULAR_ACCEL_MIN`, 2°/s².
const ANGULAR_ACCEL_MIN_RAD_S2: f64 = 2.0 * std::f64::consts::PI / 180.0;

/// `[circle]`: CIRCLE's defaults (ArduCopter's `CIRCLE_RADIUS`, `CIRCLE_RATE`, and its
/// `WPNAV_ACCEL` as the acceleration limit), in SI units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CircleParams {
    /// Radius CIRCLE flies when entered as a mode (m): ArduCopter's 1000 cm.
    pub radius_m: f64,
    /// Angular rate (deg/s), positive clockwise seen from above: ArduCopter's 20 °/s.
    pub rate_deg_s: f64,
    /// Horizontal acceleration the orbit may use (m/s²): ArduCopter's `WPNAV_ACCEL`, 2.5.
    pub accel_m_s2: f64,
}

impl Default for CircleParams {
    fn default() -> CircleParams {
        CircleParams { radius_m: 10.0, rate_deg_s: 20.0, accel_m_s2: 2.5 }
    }
}

impl CircleParams {
    pub fn validate(&self) -> Result<(), InvalidParam> {
        within("circle.radius_m", self.radius_m, 0.0, 1000.0)?;
        within("circle.rate_deg_s", self.rate_deg_s, -90.0, 90.0)?;
        within("circle.accel_m_s2", self.accel_m_s2, 0.5, 10.0)?;
        Ok(())
    }
}

/// Where the orbit point is this step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CircleTarget {
    /// North, east of the point on the circle (m).
    pub position_ne_m: [f64; 2],
    /// Its velocity (m/s) and centripetal plus tangential acceleration (m/s²).
    pub velocity_ne_m_s: [f64; 2],
    pub accel_ne_m_s2: [f64; 2],
    /// Down coordinate held (m).
    pub down_m: f64,
    /// Heading (rad) and its rate (rad/s).
    pub yaw_rad: f64,
    pub yaw_rate_rad_s: f64,
}

/// One orbit: its centre, radius and rate, and where the point is on it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle {
    centre_ne_m: [f64; 2],
    down_m: f64,
    /// ≥ 0 (m).
    radius_m: f64,
    /// Signed target rate after the speed and acceleration limits (rad/s).
    rate_max_rad_s: f64,
    /// Angular acceleration of the point (rad/s², > 0).
    angular_accel_rad_s2: f64,
    /// Bearing of the point from the centre, from north towards east (rad).
    angle_rad: f64,
    /// Current angular rate (rad/s).
    rate_rad_s: f64,
    yaw: OrbitYaw,
    /// Heading when the orbit started (rad): held with [`OrbitYaw::HoldInitial`], and flown
    /// on the spot when the radius is 0.
    initial_yaw_rad: f64,
}

impl Circle {
    /// An orbit of `radius_m` (≥ 0) round `centre_ne_m` at `down_m`, turning at `rate_rad_s`
    /// (positive clockwise), starting from where the vehicle is (`position_ne_m`, heading
    /// `yaw_rad`) with the point at rest on the circle at the vehicle's bearing from the centre
    /// (behind the centre as seen along the heading when the vehicle is at the centre).
    /// `max_speed_m_s` and `accel_m_s2` (> 0) limit the tangential speed and set the ramp.
    #[expect(
        clippy::too_many_arguments,
        reason = "an orbit is these numbers; a struct of them would only rename them"
    )]
    pub fn new(
        centre_ne_m: [f64; 2],
        down_m: f64,
        radius_m: f64,
        rate_rad_s: f64,
        position_ne_m: [f64; 2],
        yaw_rad: f64,
        yaw: OrbitYaw,
        max_speed_m_s: f64,
        accel_m_s2: f64,
    ) -> Circle {
        let radius_m = radius_m.max(0.0);
        let (rate_max_rad_s, angular_accel_rad_s2) = if radius_m > 0.0 {
            let speed = max_speed_m_s.min((0.5 * accel_m_s2 * radius_m).sqrt());
            let limit = speed / radius_m;
            (rate_rad_s.clamp(-limit, limit), (accel_m_s2 / radius_m).max(ANGULAR_ACCEL_MIN_RAD_S2))
        } else {
            (rate_rad_s, rate_rad_s.abs().max(ANGULAR_ACCEL_MIN_RAD_S2))
        };
        let (dn, de) = (position_ne_m[0] - centre_ne_m[0], position_ne_m[1] - centre_ne_m[1]);
        let angle_rad = if dn.hypot(de) > 1e-3 { de.atan2(dn) } else { yaw_rad + std::f64::consts::PI };
        Circle {
            centre_ne_m,
            down_m,
            radius_m,
            rate_max_rad_s,
            angular_accel_rad_s2,
            angle_rad,
            rate_rad_s: 0.0,
            yaw,
            initial_yaw_rad: yaw_rad,
        }
    }

    /// CIRCLE entered as a mode: the centre `radius_m` ahead of the vehicle along its heading,
    /// so that it starts on the circle, as ArduCopter's `AC_Circle::init`.
    pub fn ahead(
        params: &CircleParams,
        position_ne_m: [f64; 2],
        down_m: f64,
        yaw_rad: f64,
        max_speed_m_s: f64,
    ) -> Circle {
        let r = params.radius_m;
        let centre = [position_ne_m[0] + r * yaw_rad.cos(), position_ne_m[1] + r * yaw_rad.sin()];
        Circle::new(
            centre,
            down_m,
            r,
            params.rate_deg_s.to_radians(),
            position_ne_m,
            yaw_rad,
            OrbitYaw::FaceCentre,
            max_speed_m_s,
            params.accel_m_s2,
        )
    }

    pub fn radius_m(&self) -> f64 {
        self.radius_m
    }

    pub fn centre_ne_m(&self) -> [f64; 2] {
        self.centre_ne_m
    }

    /// The angular rate the orbit settles at (rad/s, signed).
    pub fn rate_max_rad_s(&self) -> f64 {
        self.rate_max_rad_s
    }

    /// Advances the point by `dt_s` and returns the target.
    pub fn step(&mut self, dt_s: f64) -> CircleTarget {
        let dt_s = if dt_s.is_finite() { dt_s.max(0.0) } else { 0.0 };
        let step = self.angular_accel_rad_s2 * dt_s;
        let before = self.rate_rad_s;
        self.rate_rad_s += (self.rate_max_rad_s - self.rate_rad_s).clamp(-step, step);
        let angular_accel = if dt_s > 0.0 { (self.rate_rad_s - before) / dt_s } else { 0.0 };
        self.angle_rad = (self.angle_rad + self.rate_rad_s * dt_s).rem_euclid(std::f64::consts::TAU);
        let (s, c) = self.angle_rad.sin_cos();
        let r = self.radius_m;
        let w = self.rate_rad_s;
        let position_ne_m = [self.centre_ne_m[0] + r * c, self.centre_ne_m[1] + r * s];
        let velocity_ne_m_s = [-r * w * s, r * w * c];
        // Centripetal (−r·ω² towards the centre) plus tangential (r·α).
        let accel_ne_m_s2 = [-r * w * w * c - r * angular_accel * s, -r * w * w * s + r * angular_accel * c];
        let (yaw_rad, yaw_rate_rad_s) = if r <= 0.0 {
            self.initial_yaw_rad = (self.initial_yaw_rad + w * dt_s).rem_euclid(std::f64::consts::TAU);
            (self.initial_yaw_rad, w)
        } else {
            match self.yaw {
                // From the point towards the centre: the bearing from the centre, turned round.
                OrbitYaw::FaceCentre => (self.angle_rad + std::f64::consts::PI, w),
                OrbitYaw::HoldInitial => (self.initial_yaw_rad, 0.0),
                OrbitYaw::Tangent => (self.angle_rad + std::f64::consts::FRAC_PI_2 * w.signum(), w),
            }
        };
        CircleTarget {
            position_ne_m,
            velocity_ne_m_s,
            accel_ne_m_s2,
            down_m: self.down_m,
            yaw_rad: wrap_pi(yaw_rad),
            yaw_rate_rad_s,
        }
    }
}

fn wrap_pi(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

impl Commander {
    /// CIRCLE's setpoint: the orbit a DO_ORBIT set, or one a radius ahead (mode entered).
    pub(super) fn circle(&mut self, dt_s: f64, nav: &NavState) -> SetpointTarget {
        let max_speed = self.params.guided_speed_m_s;
        let p = nav.position_ned_m;
        let params = &self.params.circle;
        let circle = self
            .latched
            .circle
            .get_or_insert_with(|| Circle::ahead(params, [p[0], p[1]], p[2], heading(nav), max_speed));
        let t = circle.step(dt_s);
        SetpointTarget::Trajectory(TrajectorySetpoint {
            position_ned_m: [Some(t.position_ne_m[0]), Some(t.position_ne_m[1]), Some(t.down_m)],
            velocity_ned_m_s: [Some(t.velocity_ne_m_s[0]), Some(t.velocity_ne_m_s[1]), None],
            acceleration_ned_m_s2: [t.accel_ne_m_s2[0], t.accel_ne_m_s2[1], 0.0],
            yaw_rad: Some(t.yaw_rad),
            yaw_rate_rad_s: t.yaw_rate_rad_s,
            // An orbit whose centre was sent from afar is joined at no more than the guided speed.
            max_horizontal_speed_m_s: Some(max_speed),
            desired_speed_m_s: None,
        })
    }

    /// MAV_CMD_DO_ORBIT: armed and flying only; the centre (and the circle's four extremes)
    /// must pass the checks a GUIDED target passes (fence, distance, least height). Accepted,
    /// the vehicle is in CIRCLE on this orbit.
    pub(super) fn orbit(
        &mut self,
        now: Time,
        radius_m: f64,
        speed_m_s: Option<f64>,
        yaw: OrbitYaw,
        centre_ne_m: Option<[f64; 2]>,
        centre_down_m: Option<f64>,
    ) -> Result<(), Refusal> {
        if !self.armed || self.landing.state() == LandedState::OnGround {
            return refuse("orbit refused: not flying");
        }
        let Some(nav) = self.fresh_nav(now).cloned() else {
            return refuse("orbit refused: no navigation state");
        };
        // NaN: the CIRCLE default, as MAV_CMD_DO_ORBIT's definition says.
        let radius_m = if radius_m.is_nan() { self.params.circle.radius_m } else { radius_m };
        let max_radius = self.params.geofence.max_radius_m;
        if !(radius_m.is_finite() && radius_m.abs() <= max_radius) {
            return refuse(format!("orbit radius {radius_m} m refused: |radius| <= {max_radius} m"));
        }
        let max_speed = self.params.guided_speed_m_s;
        if let Some(v) = speed_m_s
            && !(v.is_finite() && v > 0.0 && v <= self.params.feasibility.max_velocity_m_s)
        {
            return refuse(format!("orbit speed {v} m/s refused"));
        }
        let p = nav.position_ned_m;
        let centre = centre_ne_m.unwrap_or([p[0], p[1]]);
        let down = centre_down_m.unwrap_or(p[2]);
        if !(centre.iter().all(|x| x.is_finite()) && down.is_finite()) {
            return refuse("orbit centre is not finite");
        }
        let r = radius_m.abs();
        for (dn, de) in [(0.0, 0.0), (r, 0.0), (-r, 0.0), (0.0, r), (0.0, -r)] {
            let point = Vector3::new(centre[0] + dn, centre[1] + de, down);
            if let Some(why) = self.guided_position_refused(&point) {
                return refuse(format!("orbit refused: {why}"));
            }
        }
        let sign = if radius_m < 0.0 { -1.0 } else { 1.0 };
        let rate_rad_s = match speed_m_s {
            Some(v) if r > 0.0 => sign * v / r,
            _ => sign * self.params.circle.rate_deg_s.abs().to_radians(),
        };
        self.set_mode(now, FlightMode::Circle)?;
        self.latched.circle = Some(Circle::new(
            centre,
            down,
            r,
            rate_rad_s,
            [p[0], p[1]],
            heading(&nav),
            yaw,
            max_speed,
            self.params.circle.accel_m_s2,
        ));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    fn orbit(radius_m: f64, rate_deg_s: f64) -> Circle {
        Circle::new(
            [0.0, 0.0],
            -10.0,
            radius_m,
            rate_deg_s.to_radians(),
            [radius_m, 0.0],
            0.0,
            OrbitYaw::FaceCentre,
            5.0,
            2.5,
        )
    }

    #[test]
    fn ardupilot_defaults_settle_at_twenty_degrees_a_second_on_a_ten_metre_circle() {
        // AC_Circle: v_max = min(WPNAV_SPEED 10 m/s, sqrt(0.5 · 2.5 · 10) = 3.54 m/s), so
        // ω_max = 0.354 rad/s = 20.3 °/s and CIRCLE_RATE's 20 °/s stands.
        let c = Circle::ahead(&CircleParams::default(), [0.0, 0.0], -10.0, 0.0, 10.0);
        assert!((c.rate_max_rad_s() - 20f64.to_radians()).abs() < 1e-12);
        assert_eq!(c.centre_ne_m(), [10.0, 0.0], "the centre is a radius ahead");
    }

    #[test]
    fn the_rate_is_limited_by_the_acceleration_and_speed_limits() {
        // 90 °/s on 10 m would be 15.7 m/s: sqrt(0.5 · 2.5 · 10) = 3.536 m/s bounds it.
        let c = orbit(10.0, 90.0);
        assert!((c.rate_max_rad_s() - (12.5f64).sqrt() / 10.0).abs() < 1e-12);
        // On 100 m the speed limit (5 m/s) is the smaller one; counter-clockwise keeps its sign.
        let c = orbit(100.0, -90.0);
        assert!((c.rate_max_rad_s() + 0.05).abs() < 1e-12);
    }

    #[test]
    fn the_point_follows_the_closed_form_path_once_at_rate() {
        // Reference: after the ramp (ω_max / α seconds), θ(t) = θ_ramp + ω (t − t_ramp), and the
        // point is r·(cos θ, sin θ); the velocity is tangential of size r·ω, and the nose on the
        // centre.
        let mut c = orbit(10.0, 20.0);
        let (w, alpha) = (20f64.to_radians(), 0.25);
        let t_ramp = w / alpha;
        let theta_ramp = 0.5 * alpha * t_ramp * t_ramp;
        let dt = 0.0025;
        let mut t = 0.0;
        let mut last = None;
        while t < 20.0 {
            last = Some(c.step(dt));
            t += dt;
        }
        let target = last.unwrap();
        let theta = theta_ramp + w * (t - t_ramp);
        let expect = [10.0 * theta.cos(), 10.0 * theta.sin()];
        let err = (target.position_ne_m[0] - expect[0]).hypot(target.position_ne_m[1] - expect[1]);
        assert!(err < 0.02, "{err} m from the closed form");
        let speed = target.velocity_ne_m_s[0].hypot(target.velocity_ne_m_s[1]);
        assert!((speed - 10.0 * w).abs() < 1e-9);
        let to_centre = (-target.position_ne_m[1]).atan2(-target.position_ne_m[0]);
        assert!(wrap_pi(target.yaw_rad - to_centre).abs() < 1e-9);
        let accel = target.accel_ne_m_s2[0].hypot(target.accel_ne_m_s2[1]);
        assert!((accel - 10.0 * w * w).abs() < 1e-9, "centripetal only once at rate");
    }

    #[test]
    fn positive_rates_turn_clockwise_seen_from_above() {
        // Starting due north of the centre, clockwise goes east first.
        let mut c = Circle::new([0.0, 0.0], 0.0, 5.0, 0.3, [5.0, 0.0], 0.0, OrbitYaw::FaceCentre, 5.0, 2.5);
        for _ in 0..400 {
            c.step(0.0025);
        }
        assert!(c.step(0.0025).position_ne_m[1] > 0.0);
    }

    #[test]
    fn radius_zero_turns_on_the_spot() {
        let mut c = Circle::new([1.0, 2.0], -5.0, 0.0, 0.5, [1.0, 2.0], 0.0, OrbitYaw::FaceCentre, 5.0, 2.5);
        let mut t = c.step(0.0025);
        for _ in 0..1000 {
            t = c.step(0.0025);
        }
        assert_eq!(t.position_ne_m, [1.0, 2.0]);
        assert!(t.yaw_rad > 0.5 && (t.yaw_rate_rad_s - 0.5).abs() < 1e-9);
    }

    #[test]
    fn yaw_behaviours_hold_initial_and_tangent() {
        let mut c = Circle::new([0.0, 0.0], 0.0, 5.0, 0.3, [5.0, 0.0], 1.0, OrbitYaw::HoldInitial, 5.0, 2.5);
        assert_eq!(c.step(0.1).yaw_rad, 1.0);
        let mut c = Circle::new([0.0, 0.0], 0.0, 5.0, 0.3, [5.0, 0.0], 1.0, OrbitYaw::Tangent, 5.0, 2.5);
        let t = c.step(0.1);
        // At the north of the circle, turning clockwise, the direction of travel is east.
        let along = t.velocity_ne_m_s[1].atan2(t.velocity_ne_m_s[0]);
        assert!(wrap_pi(t.yaw_rad - along).abs() < 1e-6 && (along - PI / 2.0).abs() < 0.1);
    }

    proptest! {
        #[test]
        fn the_point_stays_on_the_circle_within_the_speed_and_acceleration_limits(
            radius in 0.5f64..200.0,
            rate_deg in -90.0f64..90.0,
            speed in 0.5f64..15.0,
            accel in 0.5f64..10.0,
            steps in 1usize..4000,
        ) {
            let mut c = Circle::new([3.0, -4.0], -10.0, radius, rate_deg.to_radians(), [3.0 + radius, -4.0], 0.0, OrbitYaw::FaceCentre, speed, accel);
            for _ in 0..steps {
                let t = c.step(0.0025);
                let r = (t.position_ne_m[0] - 3.0).hypot(t.position_ne_m[1] + 4.0);
                prop_assert!((r - radius).abs() < 1e-6 * radius.max(1.0));
                let v = t.velocity_ne_m_s[0].hypot(t.velocity_ne_m_s[1]);
                prop_assert!(v <= speed + 1e-9 && v <= (0.5 * accel * radius).sqrt() + 1e-9);
                prop_assert!(t.yaw_rad.abs() <= PI + 1e-12 && t.down_m == -10.0);
            }
        }
    }
}
