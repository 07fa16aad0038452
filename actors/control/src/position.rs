//! The outer, position loops (thesis Fig. 3.17): P on position → PID on velocity → thrust
//! vector → attitude and collective thrust.
//!
//! This follows PX4's `PositionControl` (src/modules/mc_pos_control/PositionControl): a
//! velocity setpoint from the position error plus feed-forward, limited in horizontal speed
//! and climb/descent rate; an acceleration setpoint from the velocity PID plus feed-forward;
//! the thrust vector from the acceleration with *hover-thrust scaling* (the hover thrust
//! produces 1 g, so the loop gains do not depend on mass or motors); the tilt limit; vertical
//! thrust priority with a horizontal margin; and anti-windup — the vertical integrator stops
//! while the thrust is saturated in the error's direction, the horizontal one uses tracking
//! anti-reset windup (Rundqwist 1990) with gain 2/K_p.
//!
//! Axes are NED; thrust is a share of the frame's maximum (0..1) along the thrust direction,
//! which points *up* (−z), so a level hover is `(0, 0, −hover_thrust)`.

use kestrel_proto::messages::TrajectorySetpoint;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector2, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, non_negative, positive, within};
use kestrel_proto::units::GRAVITY_M_S2;

/// `[position]` gains and limits. Defaults are PX4's multicopter defaults, checked on quad_x.toml.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PositionGains {
    /// Velocity per metre of position error, north/east/down (1/s).
    pub position_p: [f64; 3],
    /// Acceleration per m/s of velocity error (1/s).
    pub velocity_p: [f64; 3],
    /// Acceleration per metre of integrated velocity error (1/s²).
    pub velocity_i: [f64; 3],
    /// Largest horizontal speed (m/s).
    pub max_horizontal_speed_m_s: f64,
    /// Largest climb rate (m/s).
    pub max_climb_m_s: f64,
    /// Largest descent rate (m/s).
    pub max_descent_m_s: f64,
    /// Largest tilt of the thrust axis from vertical (degrees).
    pub max_tilt_deg: f64,
    /// Least collective thrust in flight, share of maximum (keeps the motors spinning).
    pub min_thrust: f64,
    /// Most collective thrust, share of maximum (keeps margin for attitude control).
    pub max_thrust: f64,
    /// Horizontal thrust always left available when the vertical loop saturates (share).
    pub horizontal_thrust_margin: f64,
    /// Collective thrust that hovers, share of maximum; `None` computes it from the airframe.
    pub hover_thrust: Option<f64>,
}

impl Default for PositionGains {
    fn default() -> PositionGains {
        PositionGains {
            position_p: [0.95, 0.95, 1.0],
            velocity_p: [1.8, 1.8, 4.0],
            velocity_i: [0.4, 0.4, 2.0],
            max_horizontal_speed_m_s: 8.0,
            max_climb_m_s: 3.0,
            max_descent_m_s: 1.5,
            max_tilt_deg: 35.0,
            min_thrust: 0.08,
            max_thrust: 0.9,
            horizontal_thrust_margin: 0.15,
            hover_thrust: None,
        }
    }
}

impl PositionGains {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        for a in 0..3 {
            positive(&format!("position.position_p[{a}]"), self.position_p[a])?;
            positive(&format!("position.velocity_p[{a}]"), self.velocity_p[a])?;
            non_negative(&format!("position.velocity_i[{a}]"), self.velocity_i[a])?;
        }
        positive("position.max_horizontal_speed_m_s", self.max_horizontal_speed_m_s)?;
        positive("position.max_climb_m_s", self.max_climb_m_s)?;
        positive("position.max_descent_m_s", self.max_descent_m_s)?;
        within("position.max_tilt_deg", self.max_tilt_deg, 1.0, 89.0)?;
        within("position.min_thrust", self.min_thrust, 0.0, 0.5)?;
        within("position.max_thrust", self.max_thrust, self.min_thrust + 0.05, 1.0)?;
        within("position.horizontal_thrust_margin", self.horizontal_thrust_margin, 0.0, 0.5)?;
        if let Some(h) = self.hover_thrust {
            within("position.hover_thrust", h, 0.05, 0.9)?;
        }
        Ok(())
    }
}

/// What the position loop asks of the attitude loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttitudeThrust {
    /// Desired attitude, body FRD → NED.
    pub attitude: UnitQuaternion<f64>,
    /// Collective thrust along the desired thrust axis, share of maximum.
    pub thrust: f64,
    /// Heading-rate feed-forward (rad/s).
    pub yaw_rate_rad_s: f64,
}

/// Position and velocity PID state.
#[derive(Clone, Debug)]
pub struct PositionController {
    gains: PositionGains,
    hover_thrust: f64,
    /// Velocity integral, as acceleration (m/s²), NED.
    integral: Vector3<f64>,
}

impl PositionController {
    /// `hover_thrust` is the airframe's (used when the gains do not override it).
    pub fn new(gains: PositionGains, hover_thrust: f64) -> PositionController {
        let hover_thrust = gains.hover_thrust.unwrap_or(hover_thrust);
        PositionController { gains, hover_thrust, integral: Vector3::zeros() }
    }

    /// Takes new (validated) gains from the next step on, keeping the integral and the hover
    /// thrust chosen at construction.
    pub fn set_gains(&mut self, gains: PositionGains) {
        self.gains = gains;
    }

    /// Forgets the integral (on the ground).
    pub fn reset(&mut self) {
        self.integral = Vector3::zeros();
    }

    /// The velocity integral (m/s²), for tests and logs.
    pub fn integral(&self) -> Vector3<f64> {
        self.integral
    }

    /// One step: the attitude and thrust that track `sp` from position `pos` and velocity
    /// `vel` (NED, m and m/s); `yaw_rad` is the heading to hold.
    pub fn update(
        &mut self,
        sp: &TrajectorySetpoint,
        pos: &Vector3<f64>,
        vel: &Vector3<f64>,
        yaw_rad: f64,
        dt_s: f64,
    ) -> AttitudeThrust {
        let g = &self.gains;
        let vel_sp = self.velocity_setpoint(sp, pos);
        let mut acc_sp = Vector3::from(sp.acceleration_ned_m_s2);
        let mut vel_error = Vector3::zeros();
        for a in 0..3 {
            if let Some(v) = vel_sp[a] {
                vel_error[a] = v - vel[a];
                acc_sp[a] += g.velocity_p[a] * vel_error[a] + self.integral[a];
            }
        }
        let mut thrust = self.thrust_vector(&acc_sp);
        // Vertical anti-windup: no integration further into a saturated thrust.
        let up = -thrust.z;
        if (up <= g.min_thrust && vel_error.z >= 0.0) || (up >= g.max_thrust && vel_error.z <= 0.0) {
            vel_error.z = 0.0;
        }
        // Vertical priority with a horizontal margin.
        let xy = Vector2::new(thrust.x, thrust.y);
        let max2 = g.max_thrust * g.max_thrust;
        let allocated_xy = xy.norm().min(g.horizontal_thrust_margin);
        thrust.z = thrust.z.max(-(max2 - allocated_xy * allocated_xy).max(0.0).sqrt());
        let max_xy = (max2 - thrust.z * thrust.z).max(0.0).sqrt();
        if xy.norm() > max_xy {
            let limited = xy * (max_xy / xy.norm());
            thrust.x = limited.x;
            thrust.y = limited.y;
        }
        // Horizontal tracking anti-windup.
        let produced = Vector2::new(thrust.x, thrust.y) * (GRAVITY_M_S2 / self.hover_thrust);
        let wanted = Vector2::new(acc_sp.x, acc_sp.y);
        let limited = if wanted.norm_squared() > produced.norm_squared() { produced } else { wanted };
        let arw_gain = 2.0 / g.velocity_p[0];
        vel_error.x -= arw_gain * (wanted.x - limited.x);
        vel_error.y -= arw_gain * (wanted.y - limited.y);
        for a in 0..3 {
            if vel_sp[a].is_some() && vel_error[a].is_finite() {
                self.integral[a] += g.velocity_i[a] * vel_error[a] * dt_s;
            }
        }
        self.integral.z = self.integral.z.clamp(-GRAVITY_M_S2, GRAVITY_M_S2);
        let xy_limit = GRAVITY_M_S2 * g.max_tilt_deg.to_radians().tan();
        let xy_int = Vector2::new(self.integral.x, self.integral.y);
        if xy_int.norm() > xy_limit {
            let l = xy_int * (xy_limit / xy_int.norm());
            self.integral.x = l.x;
            self.integral.y = l.y;
        }
        let yaw = sp.yaw_rad.unwrap_or(yaw_rad);
        AttitudeThrust {
            attitude: thrust_to_attitude(&thrust, yaw),
            thrust: thrust.norm(),
            yaw_rate_rad_s: sp.yaw_rate_rad_s,
        }
    }

    fn velocity_setpoint(&self, sp: &TrajectorySetpoint, pos: &Vector3<f64>) -> [Option<f64>; 3] {
        let g = &self.gains;
        let mut v = [None; 3];
        for (a, slot) in v.iter_mut().enumerate() {
            *slot = match (sp.position_ned_m[a], sp.velocity_ned_m_s[a]) {
                (Some(p), ff) => Some(g.position_p[a] * (p - pos[a]) + ff.unwrap_or(0.0)),
                (None, v) => v,
            };
        }
        let max_xy = sp
            .max_horizontal_speed_m_s
            .map_or(g.max_horizontal_speed_m_s, |m| m.clamp(0.0, g.max_horizontal_speed_m_s));
        if let (Some(n), Some(e)) = (v[0], v[1]) {
            let speed = n.hypot(e);
            if speed > max_xy {
                v[0] = Some(n * max_xy / speed);
                v[1] = Some(e * max_xy / speed);
            }
        }
        v[2] = v[2].map(|d| d.clamp(-g.max_climb_m_s, g.max_descent_m_s));
        v
    }

    /// Acceleration setpoint (NED, m/s², gravity excluded) → thrust vector (share, NED), with
    /// hover-thrust scaling and the tilt limit.
    fn thrust_vector(&self, acc_sp: &Vector3<f64>) -> Vector3<f64> {
        let g = &self.gains;
        // Body z (down, opposite the thrust) that produces the horizontal acceleration.
        let mut body_z = Vector3::new(-acc_sp.x, -acc_sp.y, GRAVITY_M_S2 - acc_sp.z);
        body_z = if body_z.norm() > 1e-9 { body_z.normalize() } else { Vector3::z() };
        let max_tilt = g.max_tilt_deg.to_radians();
        if body_z.z.clamp(-1.0, 1.0).acos() > max_tilt {
            let xy = Vector2::new(body_z.x, body_z.y);
            let xy = if xy.norm() > 1e-9 { xy.normalize() } else { Vector2::x() } * max_tilt.sin();
            body_z = Vector3::new(xy.x, xy.y, max_tilt.cos());
        }
        // Hover thrust produces 1 g; the vertical component is what the vertical loop asked.
        let collective =
            (acc_sp.z * (self.hover_thrust / GRAVITY_M_S2) - self.hover_thrust).min(-g.min_thrust);
        body_z * (collective / body_z.z)
    }
}

/// Attitude whose thrust axis (body −z) points along `thrust` and whose heading is `yaw_rad`
/// (PX4 `ControlMath::bodyzToAttitude`).
pub fn thrust_to_attitude(thrust: &Vector3<f64>, yaw_rad: f64) -> UnitQuaternion<f64> {
    let body_z = if thrust.norm() > 1e-9 { -thrust.normalize() } else { Vector3::z() };
    let y_c = Vector3::new(-yaw_rad.sin(), yaw_rad.cos(), 0.0);
    let mut body_x = y_c.cross(&body_z);
    if body_x.norm() < 1e-6 {
        // Thrust horizontal: keep the heading's forward as well as possible.
        body_x = Vector3::new(yaw_rad.cos(), yaw_rad.sin(), 0.0);
    }
    let body_x = body_x.normalize();
    let body_y = body_z.cross(&body_x);
    let r = Matrix3::from_columns(&[body_x, body_y, body_z]);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r))
}

/// Heading of an attitude (rad, from north towards east).
pub fn yaw_of(q: &UnitQuaternion<f64>) -> f64 {
    kestrel_proto::attitude::euler_rad([q.w, q.i, q.j, q.k])[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hold(pos: [f64; 3]) -> TrajectorySetpoint {
        TrajectorySetpoint {
            position_ned_m: pos.map(Some),
            yaw_rad: Some(0.0),
            ..TrajectorySetpoint::default()
        }
    }

    #[test]
    fn at_the_setpoint_it_hovers_level() {
        let mut ctl = PositionController::new(PositionGains::default(), 0.33);
        let out = ctl.update(
            &hold([0.0, 0.0, -10.0]),
            &Vector3::new(0.0, 0.0, -10.0),
            &Vector3::zeros(),
            0.0,
            0.0025,
        );
        assert!((out.thrust - 0.33).abs() < 1e-9);
        assert!(out.attitude.angle() < 1e-9);
    }

    #[test]
    fn far_setpoints_respect_the_tilt_and_thrust_limits() {
        let mut ctl = PositionController::new(PositionGains::default(), 0.33);
        let out = ctl.update(&hold([1000.0, 0.0, -500.0]), &Vector3::zeros(), &Vector3::zeros(), 0.0, 0.0025);
        let tilt = (out.attitude * Vector3::z()).angle(&Vector3::z());
        assert!(tilt <= 35f64.to_radians() + 1e-9, "tilt {}", tilt.to_degrees());
        assert!(out.thrust <= 0.9 + 1e-9);
        // Pitch forward (nose down) to fly north.
        assert!((out.attitude * Vector3::x()).z > 0.0);
    }

    #[test]
    fn horizontal_integrator_does_not_wind_up_while_saturated() {
        let mut ctl = PositionController::new(PositionGains::default(), 0.33);
        let sp = TrajectorySetpoint {
            velocity_ned_m_s: [Some(30.0), Some(0.0), Some(0.0)],
            ..TrajectorySetpoint::default()
        };
        for _ in 0..4000 {
            ctl.update(&sp, &Vector3::zeros(), &Vector3::zeros(), 0.0, 0.0025);
        }
        let naive = 0.4 * 8.0 * 10.0;
        assert!(ctl.integral().x < 0.2 * naive, "integral {}", ctl.integral());
    }

    #[test]
    fn thrust_along_north_tilts_the_nose_down() {
        let q = thrust_to_attitude(&Vector3::new(0.1, 0.0, -0.3), 0.0);
        assert!((q * Vector3::x()).z > 0.0);
        assert!(yaw_of(&q).abs() < 1e-9);
        let q = thrust_to_attitude(&Vector3::new(0.0, 0.0, -0.3), 1.0);
        assert!((yaw_of(&q) - 1.0).abs() < 1e-9);
    }
}
