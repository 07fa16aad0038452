//! The airframe as the controller sees it: mass, inertia, motor layout and thrust limits.
//!
//! Motor order, bearings and spins are `kestrel_proto::frame_layout` (ArduPilot/PX4
//! numbering), the table the simulator builds its motors from too.
//! Defaults are `config/vehicles/quad_x.toml`. In a graph that names its vehicle file (the
//! top-level `vehicle`), the runtime derives this from that file, the one the simulator flies
//! (`src/vehicle.rs`), and refuses at start a graph that writes it otherwise.

use kestrel_proto::frame_layout::FrameLayout;
use kestrel_proto::messages::MAX_MOTORS;
use kestrel_proto::units::GRAVITY_M_S2;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, positive};

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
    pub frame: FrameLayout,
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
            frame: FrameLayout::QuadX,
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
