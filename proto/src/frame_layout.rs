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

    #[test]
    fn quad_x_motor_one_is_front_right_counter_clockwise() {
        let m1 = FrameLayout::QuadX.motors(1.0).next().unwrap();
        assert!(m1.position_frd_m.x > 0.0 && m1.position_frd_m.y > 0.0);
        assert_eq!(m1.spin, Spin::CounterClockwise);
    }
}
