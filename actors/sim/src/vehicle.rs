//! The vehicle file: airframe, motors, drag, battery, ground contact and sensors.

use std::path::Path;

use kestrel_proto::frame_layout::FrameLayout;
use kestrel_proto::units::GRAVITY_M_S2;
use serde::{Deserialize, Serialize};

use crate::battery::BatteryParams;
use crate::config_file;
use crate::drag::DragParams;
use crate::error::{ConfigError, InvalidParam, positive};
use crate::ground::ContactParams;
use crate::motors::MotorParams;
use crate::sensors::SensorParams;

/// A multirotor, as `config/vehicles/*.toml` describes it. Defaults are a ~1.5 kg 450-size
/// quad-X like the thesis's (850 KV motors, 10" propellers, 4S 3300 mAh).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VehicleParams {
    /// Take-off mass, battery included (kg).
    pub mass_kg: f64,
    /// Principal moments of inertia about forward, right, down (kg·m²); products of inertia
    /// are taken as zero (a symmetric frame).
    pub inertia_frd_kg_m2: [f64; 3],
    /// Centre of mass to each motor's axis (m); 0.225 m for a 450 mm frame.
    pub arm_length_m: f64,
    /// Motor positions and spins.
    pub frame: FrameLayout,
    /// `[motor]`: one motor-propeller pair (all motors are alike).
    pub motor: MotorParams,
    /// `[drag]`: airframe drag against the air.
    pub drag: DragParams,
    /// `[battery]`: the flight pack.
    pub battery: BatteryParams,
    /// `[contact]`: ground-contact and collision limits.
    pub contact: ContactParams,
    /// `[sensors.*]`: IMU, GPS, barometer, magnetometer, rangefinders.
    pub sensors: SensorParams,
}

impl Default for VehicleParams {
    fn default() -> VehicleParams {
        VehicleParams {
            mass_kg: 1.5,
            inertia_frd_kg_m2: [0.029, 0.029, 0.055],
            arm_length_m: 0.225,
            frame: FrameLayout::QuadX,
            motor: MotorParams::default(),
            drag: DragParams::default(),
            battery: BatteryParams::default(),
            contact: ContactParams::default(),
            sensors: SensorParams::default(),
        }
    }
}

impl VehicleParams {
    /// Loads and checks a vehicle file.
    pub fn load(path: &Path) -> Result<VehicleParams, ConfigError> {
        config_file::load(path, VehicleParams::validate)
    }

    /// Checks every field; the error names the offending one.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        positive("mass_kg", self.mass_kg)?;
        for (i, &inertia) in self.inertia_frd_kg_m2.iter().enumerate() {
            positive(&format!("inertia_frd_kg_m2[{i}]"), inertia)?;
        }
        positive("arm_length_m", self.arm_length_m)?;
        self.motor.validate().map_err(|e| e.within("motor"))?;
        self.motor.validate_for(self.frame.motor_count()).map_err(|e| e.within("motor"))?;
        self.drag.validate().map_err(|e| e.within("drag"))?;
        self.battery.validate().map_err(|e| e.within("battery"))?;
        self.contact.validate().map_err(|e| e.within("contact"))?;
        self.sensors.validate().map_err(|e| e.within("sensors"))?;
        let max_thrust_n = self.motor.max_thrust_n() * self.frame.motor_count() as f64;
        if max_thrust_n <= self.mass_kg * GRAVITY_M_S2 {
            return Err(InvalidParam::new(
                "motor.thrust_coefficient_n_per_rad2_s2",
                format!(
                    "gives {max_thrust_n:.1} N at full throttle, not enough to lift {:.2} kg",
                    self.mass_kg
                ),
            ));
        }
        Ok(())
    }
}

/// The motor command (0..1, the same on every motor) at which the vehicle hovers: thrust equals
/// weight. Above 1 when the motors cannot lift the vehicle, which `validate` rejects.
pub fn hover_throttle(vehicle: &VehicleParams) -> f64 {
    let per_motor_n = vehicle.mass_kg * GRAVITY_M_S2 / vehicle.frame.motor_count() as f64;
    per_motor_n / vehicle.motor.max_thrust_n()
}
