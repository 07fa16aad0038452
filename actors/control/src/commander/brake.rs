//! BRAKE: stop as fast as the vehicle can, then hold where it stopped.
//!
//! As ArduCopter's `ModeBrake`: the horizontal velocity target falls to zero at
//! `BRAKE_MODE_DECEL_RATE` (7.5 m/s²), bounded here by what the tilt limit can give
//! (g·tan(max tilt)), and the height is held (zero climb rate); once the target is zero the
//! vehicle holds the position it is at. Held by `tests::brake` (the ramp in closed form) and the
//! closed-loop flight in `actors/control/tests/modes.rs` (stopping distance and drift).

use kestrel_proto::messages::{NavState, SetpointTarget, TrajectorySetpoint};
use kestrel_proto::units::GRAVITY_M_S2;

use super::{Commander, heading};

/// ArduCopter's `BRAKE_MODE_DECEL_RATE`: 750 cm/s² (m/s²).
pub const BRAKE_DECEL_M_S2: f64 = 7.5;

/// What BRAKE targets this step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BrakeTarget {
    /// Slowing down: this velocity (m/s) with this acceleration feed-forward (m/s²).
    Slowing { velocity_ne_m_s: [f64; 2], accel_ne_m_s2: [f64; 2], down_m: f64 },
    /// Stopped: hold here (m).
    Hold { position_ned_m: [f64; 3] },
}

impl BrakeTarget {
    /// The trajectory setpoint that flies this target with the nose at `yaw_rad`: the velocity
    /// with its feed-forward at the held height while slowing, then the point.
    pub fn setpoint(self, yaw_rad: f64) -> TrajectorySetpoint {
        match self {
            BrakeTarget::Slowing { velocity_ne_m_s: [vn, ve], accel_ne_m_s2: [an, ae], down_m } => {
                TrajectorySetpoint {
                    position_ned_m: [None, None, Some(down_m)],
                    velocity_ned_m_s: [Some(vn), Some(ve), None],
                    acceleration_ned_m_s2: [an, ae, 0.0],
                    yaw_rad: Some(yaw_rad),
                    ..TrajectorySetpoint::default()
                }
            }
            BrakeTarget::Hold { position_ned_m } => TrajectorySetpoint {
                position_ned_m: position_ned_m.map(Some),
                yaw_rad: Some(yaw_rad),
                ..TrajectorySetpoint::default()
            },
        }
    }
}

/// A braking vehicle: the velocity target still to shed, then the point held.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Brake {
    velocity_ne_m_s: [f64; 2],
    down_m: f64,
    hold: Option<[f64; 3]>,
}

impl Brake {
    /// Braking from `velocity_ne_m_s` (the vehicle's, m/s), holding `down_m`.
    pub fn new(velocity_ne_m_s: [f64; 2], down_m: f64) -> Brake {
        let v = if velocity_ne_m_s.iter().all(|x| x.is_finite()) { velocity_ne_m_s } else { [0.0; 2] };
        Brake { velocity_ne_m_s: v, down_m, hold: None }
    }

    /// Sheds `decel_m_s2` · `dt_s` of the velocity target; once it is zero, holds the position
    /// the vehicle is at (`position_ned_m`, down replaced by the height held).
    pub fn step(&mut self, dt_s: f64, decel_m_s2: f64, position_ned_m: [f64; 3]) -> BrakeTarget {
        if let Some(p) = self.hold {
            return BrakeTarget::Hold { position_ned_m: p };
        }
        let [vn, ve] = self.velocity_ne_m_s;
        let speed = vn.hypot(ve);
        let shed = decel_m_s2 * dt_s.max(0.0);
        if speed <= shed || speed == 0.0 {
            let p = [position_ned_m[0], position_ned_m[1], self.down_m];
            self.hold = Some(p);
            return BrakeTarget::Hold { position_ned_m: p };
        }
        let scale = (speed - shed) / speed;
        self.velocity_ne_m_s = [vn * scale, ve * scale];
        let (un, ue) = (vn / speed, ve / speed);
        BrakeTarget::Slowing {
            velocity_ne_m_s: self.velocity_ne_m_s,
            accel_ne_m_s2: [-decel_m_s2 * un, -decel_m_s2 * ue],
            down_m: self.down_m,
        }
    }
}

impl Commander {
    /// BRAKE's setpoint.
    pub(super) fn brake(&mut self, dt_s: f64, nav: &NavState) -> SetpointTarget {
        let yaw = *self.latched.hold.yaw_rad.get_or_insert(heading(nav));
        let v = nav.velocity_ned_m_s;
        let p = nav.position_ned_m;
        let brake = self.latched.brake.get_or_insert_with(|| Brake::new([v[0], v[1]], p[2]));
        // The tilt limit bounds the deceleration the vehicle can reach: asking for more only
        // winds up the velocity error.
        let decel = BRAKE_DECEL_M_S2.min(GRAVITY_M_S2 * self.params.max_tilt_deg.to_radians().tan());
        SetpointTarget::Trajectory(brake.step(dt_s, decel, p).setpoint(yaw))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn the_velocity_target_falls_linearly_to_zero_then_the_position_is_held() {
        // 6 m/s north-east at 5 m/s²: zero after 1.2 s, the velocity at t is 6 − 5t along the
        // same direction.
        let v0 = [6.0 / 2f64.sqrt(), 6.0 / 2f64.sqrt()];
        let mut b = Brake::new(v0, -10.0);
        let dt = 0.0025;
        for i in 1..=479 {
            let t = f64::from(i) * dt;
            match b.step(dt, 5.0, [0.0, 0.0, -9.0]) {
                BrakeTarget::Slowing { velocity_ne_m_s: v, accel_ne_m_s2: a, down_m } => {
                    assert!((v[0].hypot(v[1]) - (6.0 - 5.0 * t)).abs() < 1e-9, "t {t}");
                    assert!(
                        (v[0] - v[1]).abs() < 1e-9 && (a[0].hypot(a[1]) - 5.0).abs() < 1e-9 && a[0] < 0.0
                    );
                    assert_eq!(down_m, -10.0);
                }
                other => panic!("held at {t} s: {other:?}"),
            }
        }
        for _ in 0..3 {
            b.step(dt, 5.0, [3.0, 4.0, -9.0]);
        }
        assert_eq!(
            b.step(dt, 5.0, [9.0, 9.0, -9.0]),
            BrakeTarget::Hold { position_ned_m: [3.0, 4.0, -10.0] }
        );
    }

    #[test]
    fn at_rest_or_with_a_non_finite_velocity_it_holds_at_once() {
        assert!(matches!(
            Brake::new([0.0, 0.0], -5.0).step(0.0025, 7.5, [1.0, 2.0, -4.0]),
            BrakeTarget::Hold { .. }
        ));
        assert_eq!(
            Brake::new([f64::NAN, 1.0], -5.0).step(0.0025, 7.5, [1.0, 2.0, -4.0]),
            BrakeTarget::Hold { position_ned_m: [1.0, 2.0, -5.0] }
        );
    }

    proptest! {
        #[test]
        fn the_target_never_speeds_up_nor_turns(vn in -15.0f64..15.0, ve in -15.0f64..15.0, decel in 0.5f64..10.0) {
            let mut b = Brake::new([vn, ve], 0.0);
            let mut last = vn.hypot(ve);
            // The slowest case, 21.2 m/s at 0.5 m/s², stops after 42.4 s: 16,971 steps.
            for _ in 0..20_000 {
                match b.step(0.0025, decel, [0.0; 3]) {
                    BrakeTarget::Slowing { velocity_ne_m_s: v, .. } => {
                        let s = v[0].hypot(v[1]);
                        prop_assert!(s < last + 1e-12);
                        prop_assert!((v[0] * ve - v[1] * vn).abs() < 1e-9 * (1.0 + vn.hypot(ve)));
                        last = s;
                    }
                    BrakeTarget::Hold { .. } => return Ok(()),
                }
            }
            prop_assert!(false, "never stopped");
        }
    }
}
