//! MAV_CMD_INJECT_FAILURE as the graph carries it: the link passes a ground station's (or
//! MAVSDK's Failure plugin's) request to whoever can break things — the simulator — and turns
//! the answer into the command's COMMAND_ACK.
//!
//! The unit and type numbers are MAVLink's `FAILURE_UNIT` and `FAILURE_TYPE`, so a request reads
//! the same in a log as on the wire; which of them a simulator can inject is its own business
//! (PX4's SITL also answers UNSUPPORTED for most).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// The parameter that allows failure injection (PX4's name, which MAVSDK's Failure plugin
/// reads): 0 refuses every MAV_CMD_INJECT_FAILURE, 1 allows it. Declared by the injector.
pub const FAILURE_INJECTION_ENABLE: &str = "SYS_FAILURE_EN";

/// What fails (MAVLink `FAILURE_UNIT`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FailureUnit {
    SensorGyro,
    SensorAccel,
    SensorMag,
    SensorBaro,
    SensorGps,
    SensorOpticalFlow,
    SensorVio,
    SensorDistanceSensor,
    SensorAirspeed,
    SystemBattery,
    SystemMotor,
    SystemServo,
    SystemAvoidance,
    SystemRcSignal,
    SystemMavlinkSignal,
}

impl FailureUnit {
    /// The unit MAVLink numbers `value` (`FAILURE_UNIT`), if any.
    pub fn from_mavlink(value: u32) -> Option<FailureUnit> {
        Some(match value {
            0 => FailureUnit::SensorGyro,
            1 => FailureUnit::SensorAccel,
            2 => FailureUnit::SensorMag,
            3 => FailureUnit::SensorBaro,
            4 => FailureUnit::SensorGps,
            5 => FailureUnit::SensorOpticalFlow,
            6 => FailureUnit::SensorVio,
            7 => FailureUnit::SensorDistanceSensor,
            8 => FailureUnit::SensorAirspeed,
            100 => FailureUnit::SystemBattery,
            101 => FailureUnit::SystemMotor,
            102 => FailureUnit::SystemServo,
            103 => FailureUnit::SystemAvoidance,
            104 => FailureUnit::SystemRcSignal,
            105 => FailureUnit::SystemMavlinkSignal,
            _ => return None,
        })
    }
}

/// How it fails (MAVLink `FAILURE_TYPE`); `Ok` ends the unit's injected failures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FailureType {
    Ok,
    Off,
    Stuck,
    Garbage,
    Wrong,
    Slow,
    Delayed,
    Intermittent,
}

impl FailureType {
    /// The type MAVLink numbers `value` (`FAILURE_TYPE`), if any.
    pub fn from_mavlink(value: u32) -> Option<FailureType> {
        Some(match value {
            0 => FailureType::Ok,
            1 => FailureType::Off,
            2 => FailureType::Stuck,
            3 => FailureType::Garbage,
            4 => FailureType::Wrong,
            5 => FailureType::Slow,
            6 => FailureType::Delayed,
            7 => FailureType::Intermittent,
            _ => return None,
        })
    }
}

/// One MAV_CMD_INJECT_FAILURE, numbered by the link like a `VehicleCommand` so that the answer
/// with the same `id` becomes its COMMAND_ACK.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FailureInjection {
    pub time: Time,
    pub id: u32,
    pub unit: FailureUnit,
    pub failure: FailureType,
    /// Which one of the unit (param3): 0 all, else 1-based (for motors, the mixer's number).
    pub instance: u8,
}
crate::impl_message!(FailureInjection);

/// What the injector made of a [`FailureInjection`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum InjectionOutcome {
    /// The failure is in effect (or, for [`FailureType::Ok`], ended), as the injector names it
    /// (`gps_off from 12.5 s`).
    Accepted(String),
    /// Not allowed now, and why (injection disabled by `SYS_FAILURE_EN`, no such motor):
    /// MAV_RESULT_DENIED.
    Denied(String),
    /// A unit and type this injector cannot break, and why: MAV_RESULT_UNSUPPORTED.
    Unsupported(String),
}

/// The answer to the [`FailureInjection`] with `id`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FailureInjectionResult {
    pub time: Time,
    pub id: u32,
    pub outcome: InjectionOutcome,
}
crate::impl_message!(FailureInjectionResult);
