//! The airframe as the controller sees it: mass, inertia, motor layout and thrust limits.
//!
//! Motor order, bearings and spins mirror the simulator's `FrameLayout` (ArduPilot/PX4
//! numbering; quad-X: 1 front-right CCW, 2 rear-left CCW, 3 front-left CW, 4 rear-right CW).
//! The control crate does not depend on the simulator, so a test checks the two agree.
//! Defaults are `config/vehicles/quad_x.toml`.

use kestrel_proto::messages::MAX_MOTORS;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, positive};

/// Standard gravity (m/s²), down in NED.
pub const GRAVITY_M_S2: f64 = 9.806_65;

/// Frame geometry.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Frame {
    #[default]
    QuadX,
    HexaX,
    OctoX,
}

const CW: f64 = -1.0;
const CCW: f64 = 1.0;
/// (bearing from forward towards the right in degrees, yaw sign of the reaction torque).
const QUAD_X: [(f64, f64); 4] = [(45.0, CCW), (-135.0, CCW), (-45.0, CW), (135.0, CW)];
const HEXA_X: [(f64, f64); 6] =
    [(90.0, CW), (-90.0, CCW), (-30.0, CW), (150.0, CCW), (30.0, CCW), (-150.0, CW)];
const OCTO_X: [(f64, f64); 8] = [
    (22.5, CW),
    (-157.5, CW),
    (67.5, CCW),
    (157.5, CCW),
    (-22.5, CCW),
    (-112.5, CCW),
    (-67.5, CW),
    (112.5, CW),
];

/// One motor as the mixer needs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rotor {
    /// Hub forward of the centre of mass (m).
    pub x_m: f64,
    /// Hub right of the centre of mass (m).
    pub y_m: f64,
    /// +1 when the propeller's reaction torque yaws the body clockwise (a CCW propeller).
    pub yaw_sign: f64,
}

impl Frame {
    /// Number of motors.
    pub fn motor_count(self) -> usize {
        self.table().len()
    }

    fn table(self) -> &'static [(f64, f64)] {
        match self {
            Frame::QuadX => &QUAD_X,
            Frame::HexaX => &HEXA_X,
            Frame::OctoX => &OCTO_X,
        }
    }

    /// The rotors in mixer order, hubs `arm_length_m` from the centre.
    pub fn rotors(self, arm_length_m: f64) -> impl Iterator<Item = Rotor> {
        self.table().iter().map(move |&(bearing_deg, yaw_sign)| {
            let (sin, cos) = f64::to_radians(bearing_deg).sin_cos();
            Rotor { x_m: arm_length_m * cos, y_m: arm_length_m * sin, yaw_sign }
        })
    }
}

/// `[airframe]`: what the controller must know about the vehicle. Defaults: quad_x.toml.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AirframeParams {
    /// Take-off mass (kg).
    pub mass_kg: f64,
    /// Principal moments of inertia about forward, right, down (kg·m²).
    pub inertia_frd_kg_m2: [f64; 3],
    /// Centre of mass to each motor axis (m).
    pub arm_length_m: f64,
    pub frame: Frame,
    /// Thrust of one motor at command 1 (N); commands map linearly to thrust.
    pub max_thrust_per_motor_n: f64,
    /// Propeller drag torque over thrust (m): k_m / k_f.
    pub torque_to_thrust_m: f64,
}

impl Default for AirframeParams {
    fn default() -> AirframeParams {
        AirframeParams {
            mass_kg: 1.5,
            inertia_frd_kg_m2: [0.029, 0.029, 0.055],
            arm_length_m: 0.225,
            frame: Frame::QuadX,
            // k_f · ω_max² = 1.1e-5 · 1000².
            max_thrust_per_motor_n: 11.0,
            // k_m / k_f = 1.76e-7 / 1.1e-5.
            torque_to_thrust_m: 0.016,
        }
    }
}

impl AirframeParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        positive("airframe.mass_kg", self.mass_kg)?;
        for (i, &j) in self.inertia_frd_kg_m2.iter().enumerate() {
            positive(&format!("airframe.inertia_frd_kg_m2[{i}]"), j)?;
        }
        positive("airframe.arm_length_m", self.arm_length_m)?;
        positive("airframe.max_thrust_per_motor_n", self.max_thrust_per_motor_n)?;
        positive("airframe.torque_to_thrust_m", self.torque_to_thrust_m)?;
        if self.max_thrust_n() <= self.weight_n() {
            return Err(InvalidParam::new(
                "airframe.max_thrust_per_motor_n",
                format!("{:.1} N in all cannot lift {:.1} N", self.max_thrust_n(), self.weight_n()),
            ));
        }
        debug_assert!(self.frame.motor_count() <= MAX_MOTORS);
        Ok(())
    }

    /// Thrust of every motor at full command (N).
    pub fn max_thrust_n(&self) -> f64 {
        self.max_thrust_per_motor_n * self.frame.motor_count() as f64
    }

    /// Weight (N).
    pub fn weight_n(&self) -> f64 {
        self.mass_kg * GRAVITY_M_S2
    }

    /// Collective thrust share (0..1) that balances the weight.
    pub fn hover_thrust(&self) -> f64 {
        self.weight_n() / self.max_thrust_n()
    }
}
