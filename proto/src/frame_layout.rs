//! Where the motors sit and which way they spin, for the frames Kestrel flies.
//!
//! Motor order and spin follow ArduPilot's (and, for quad-X, PX4's) numbering, so a mixer
//! written against either reads the same: quad-X is 1 front-right CCW, 2 rear-left CCW,
//! 3 front-left CW, 4 rear-right CW. The simulator's motors and the controller's mixer both
//! read this one table, so they cannot disagree on where motor 3 is.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// The frame geometry.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FrameLayout {
    /// Four motors at ±45° and ±135° from forward.
    #[default]
    QuadX,
    /// Six motors at ±30°, ±90°, ±150° from forward.
    HexaX,
    /// Eight motors at ±22.5°, ±67.5°, ±112.5°, ±157.5° from forward.
    OctoX,
}

/// Propeller spin seen from above.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Spin {
    Clockwise,
    CounterClockwise,
}

impl Spin {
    /// Sign of the reaction torque about body down: a counter-clockwise propeller (seen from
    /// above) pushes the body clockwise, i.e. positive yaw in FRD.
    pub fn yaw_sign(self) -> f64 {
        match self {
            Spin::Clockwise => -1.0,
            Spin::CounterClockwise => 1.0,
        }
    }
}

/// One motor's place on the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorGeometry {
    /// Rotor hub relative to the centre of mass, body FRD (m).
    pub position_frd_m: Vector3<f64>,
    pub spin: Spin,
}

use Spin::{Clockwise as Cw, CounterClockwise as Ccw};

/// Bearing of each motor from forward, positive towards the right (degrees), and its spin.
const QUAD_X: [(f64, Spin); 4] = [(45.0, Ccw), (-135.0, Ccw), (-45.0, Cw), (135.0, Cw)];
const HEXA_X: [(f64, Spin); 6] =
    [(90.0, Cw), (-90.0, Ccw), (-30.0, Cw), (150.0, Ccw), (30.0, Ccw), (-150.0, Cw)];
const OCTO_X: [(f64, Spin); 8] = [
    (22.5, Cw),
    (-157.5, Cw),
    (67.5, Ccw),
    (157.5, Ccw),
    (-22.5, Ccw),
    (-112.5, Ccw),
    (-67.5, Cw),
    (112.5, Cw),
];

impl FrameLayout {
    /// Number of motors.
    pub fn motor_count(self) -> usize {
        self.bearings().len()
    }

    /// The motors, in mixer order, with hubs `arm_length_m` from the centre.
    pub fn motors(self, arm_length_m: f64) -> impl Iterator<Item = MotorGeometry> {
        self.bearings().iter().map(move |&(bearing_deg, spin)| {
            let (sin, cos) = bearing_deg.to_radians().sin_cos();
            MotorGeometry { position_frd_m: Vector3::new(arm_length_m * cos, arm_length_m * sin, 0.0), spin }
        })
    }

    /// The layout with `count` motors, if Kestrel flies one (each it flies has its own count).
    pub fn with_motor_count(count: usize) -> Option<FrameLayout> {
        [FrameLayout::QuadX, FrameLayout::HexaX, FrameLayout::OctoX]
            .into_iter()
            .find(|l| l.motor_count() == count)
    }

    /// The motors (0-based, mixer order) in ArduPilot's test order, the numbering of
    /// MAV_CMD_DO_MOTOR_TEST: clockwise from the first at or right of forward, by bearing.
    /// Entries past `motor_count` are unused (0). Quad-X: 1, 4, 2, 3 (front-right, rear-right,
    /// rear-left, front-left), as ArduCopter's motor test A..D.
    pub fn test_order(self) -> [usize; crate::messages::MAX_MOTORS] {
        let bearings = self.bearings();
        let mut order = [0; crate::messages::MAX_MOTORS];
        for (i, slot) in order.iter_mut().enumerate().take(bearings.len()) {
            *slot = i;
        }
        let key = |i: usize| bearings[i].0.rem_euclid(360.0);
        order[..bearings.len()].sort_by(|&a, &b| key(a).total_cmp(&key(b)));
        order
    }

    fn bearings(self) -> &'static [(f64, Spin)] {
        match self {
            FrameLayout::QuadX => &QUAD_X,
            FrameLayout::HexaX => &HEXA_X,
            FrameLayout::OctoX => &OCTO_X,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_thrust_gives_no_torque_on_every_frame() {
        for layout in [FrameLayout::QuadX, FrameLayout::HexaX, FrameLayout::OctoX] {
            let motors: Vec<_> = layout.motors(0.25).collect();
            let centre: Vector3<f64> = motors.iter().map(|m| m.position_frd_m).sum();
            let yaw: f64 = motors.iter().map(|m| m.spin.yaw_sign()).sum();
            assert!(centre.norm() < 1e-12, "{layout:?} {centre}");
            assert_eq!(yaw, 0.0, "{layout:?}");
            assert!(motors.iter().all(|m| (m.position_frd_m.norm() - 0.25).abs() < 1e-12));
        }
    }

    /// ArduPilot's `AP_MotorsMatrix` test order numbers (1-based) for its motors 1..n.
    #[test]
    fn test_order_is_ardupilots_for_every_frame() {
        let one_based = |l: FrameLayout| -> Vec<usize> {
            l.test_order()[..l.motor_count()].iter().map(|m| m + 1).collect()
        };
        assert_eq!(one_based(FrameLayout::QuadX), [1, 4, 2, 3]);
        assert_eq!(one_based(FrameLayout::HexaX), [5, 1, 4, 6, 2, 3]);
        assert_eq!(one_based(FrameLayout::OctoX), [1, 3, 8, 4, 2, 6, 7, 5]);
        for l in [FrameLayout::QuadX, FrameLayout::HexaX, FrameLayout::OctoX] {
            assert_eq!(FrameLayout::with_motor_count(l.motor_count()), Some(l));
        }
        assert_eq!(FrameLayout::with_motor_count(5), None);
    }

    #[test]
    fn quad_x_motor_one_is_front_right_counter_clockwise() {
        let m1 = FrameLayout::QuadX.motors(1.0).next().unwrap();
        assert!(m1.position_frd_m.x > 0.0 && m1.position_frd_m.y > 0.0);
        assert_eq!(m1.spin, Spin::CounterClockwise);
    }
}
