use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::time::Time;

/// One scalar observation as the estimator last saw it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Innovation {
    /// Measurement minus prediction, in the observation's unit (m, m/s or gauss).
    pub innovation: f64,
    /// Predicted variance of the innovation, `H P Hᵀ + R` (unit squared).
    pub variance: f64,
    /// `innovation² / (gate² · variance)`: above 1 the observation fails its chi-square gate.
    pub test_ratio: f64,
}

/// How one sensor's observations have fared since the estimator started.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct AidingCounters {
    /// Samples fused into the state.
    pub fused: u64,
    /// Samples rejected by the innovation gate.
    pub rejected: u64,
    /// Times the state was reset to this sensor (after a rejection timeout or a loss).
    pub resets: u32,
}

/// What the estimator is doing and whether it can be trusted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct EstimatorHealth {
    /// Roll and pitch aligned from the accelerometer on a still vehicle.
    pub tilt_aligned: bool,
    /// Yaw aligned from the magnetometer.
    pub yaw_aligned: bool,
    /// A local NED origin exists (first good 3D GPS fix seen).
    pub origin_set: bool,
    /// GPS position or velocity fused within the position timeout.
    pub gps_fusing: bool,
    /// Barometer height fused within the timeout.
    pub baro_fusing: bool,
    /// Magnetometer fused within the timeout.
    pub mag_fusing: bool,
    /// Drag is fused in GPS's place: the velocity is measured from the accelerometer against
    /// the wind learnt before GPS was lost (PX4 EKF2's `fuse_drag`).
    #[serde(default)]
    pub drag_fusing: bool,
    /// No horizontal aiding for longer than the timeout: position is dead reckoned.
    pub dead_reckoning: bool,
    /// Fusions skipped because they would have made a variance negative.
    pub numerical_faults: u32,
    /// IMU samples dropped because they were out of order or had an unusable interval.
    pub imu_rejected: u64,
    /// IMU samples used although some gyro or accelerometer axis was at full scale: the
    /// prediction then understates the motion (PX4's EKF2 counts and de-weights such accel
    /// axes). Absent in older logs, which read as 0.
    #[serde(default)]
    pub imu_clipped: u64,
    /// Times the IMU stream stopped and resumed in flight (the state's uncertainty was reset).
    #[serde(default)]
    pub imu_gaps: u32,
    /// The barometer was rejected for too long, or moved away from the height propagated on GPS
    /// velocity while GPS height did not: height from GPS.
    #[serde(default)]
    pub baro_faulty: bool,
    /// GPS height moved away from the barometer and the height propagated on GPS velocity: it
    /// is not used.
    #[serde(default)]
    pub gps_height_faulty: bool,
    /// A GPS position reset was refused for moving the position further than the estimator's
    /// limit (the distance, whole m), and GPS position has not come back inside its gate: the
    /// horizontal position is reported invalid.
    #[serde(default)]
    pub gps_reset_refused_m: Option<u32>,
    /// Times the prediction moved to another IMU because the one in use fell silent.
    #[serde(default)]
    pub imu_switches: u32,
    /// Times a restarted estimator resumed the state its predecessor kept (instead of aligning
    /// again, which needs a still vehicle).
    #[serde(default)]
    pub warm_starts: u32,
    /// Times an aligned filter was dropped to align again on a vehicle at rest because a sensor
    /// calibration changed (a burst of changes counts once).
    #[serde(default)]
    pub realignments: u32,
}

/// The estimator's innovations, gate test ratios, counters and health, published at ~10 Hz.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct EstimatorStatus {
    /// IMU time of the newest state.
    pub time: Time,
    /// GPS north, east position (m).
    pub gps_position_ne: [Innovation; 2],
    /// GPS north, east, down velocity (m/s).
    pub gps_velocity_ned: [Innovation; 3],
    /// Barometric height, expressed as down position (m).
    pub baro_height: Innovation,
    /// Barometric climb rate, expressed as down velocity (m/s).
    pub baro_climb_rate: Innovation,
    /// Magnetometer body forward, right, down field (gauss).
    pub mag_field: [Innovation; 3],
    /// Body forward and right air velocity measured from drag (m/s).
    #[serde(default)]
    pub drag_air_velocity: [Innovation; 2],
    pub gps: AidingCounters,
    pub baro: AidingCounters,
    pub mag: AidingCounters,
    #[serde(default)]
    pub drag: AidingCounters,
    /// The wind (m/s, north and east: the air's velocity over the ground) learnt from drag
    /// while GPS velocity was fused; `None` before it is learnt or without a drag model.
    #[serde(default)]
    pub wind_ne_m_s: Option<[f64; 2]>,
    pub health: EstimatorHealth,
    /// Age of the delayed fusion horizon behind the newest IMU sample (s).
    pub fusion_horizon_s: f64,
}
crate::impl_message!(EstimatorStatus);
