//! Sensor models: what the flight computer would read, with noise, bias and lag.
//!
//! Sensor parameters live in the vehicle file's `[sensors.*]` tables (the sensors belong to the
//! airframe, not to the world). Every model draws from its own seeded random stream, so
//! changing one sensor's settings never changes another's noise.
//!
//! Defaults follow the thesis's hardware (Navio2: MPU-9250 IMU, MS5611 barometer, u-blox M8N
//! GPS) at the rates and lags the thesis used (IMU 400 Hz; GPS 5 Hz, 220 ms; baro 10 Hz, 50 ms).
//! The thesis flew no rangefinder; the optional ones default to a Benewake TFmini Plus.
//! The thesis's EKF noise settings (GPS 0.5 m and 0.5 m/s, baro 2 m, accel 0.25 m/s²) are
//! tuning values and deliberately larger than the simulated sensors' noise, except GPS
//! horizontal position, where 0.5 m is used as is.

pub mod baro;
pub mod gps;
pub mod imu;
pub mod mag;
pub(crate) mod noise;
pub mod rangefinder;
pub(crate) mod schedule;

use nalgebra::UnitQuaternion;
use serde::{Deserialize, Serialize};

use crate::error::{InvalidParam, finite};

pub use baro::BaroParams;
pub use gps::GpsParams;
pub use imu::ImuParams;
pub use mag::MagParams;
pub use rangefinder::RangefinderParams;

/// Every sensor's settings.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorParams {
    /// `[sensors] board_rotation_deg = [roll, pitch, yaw]`: the sensor board (IMU and
    /// magnetometer) against the airframe, aerospace Z-Y-X angles (degrees) of the rotation
    /// that turns board axes into airframe axes; the sensors read airframe vectors turned into
    /// the board. Default level, `[0, 0, 0]`.
    pub board_rotation_deg: [f64; 3],
    /// `[sensors.imu]`: the first IMU, the one the estimator uses while it delivers (the
    /// Navio2's MPU-9250). Faults and calibration apply to it.
    pub imu: ImuParams,
    /// `[sensors.imu2]`: a second IMU on the board (the Navio2's LSM9DS1), published on `imu2`
    /// with its own noise and biases, so that the first one stopping is a failover; absent on a
    /// board with one. Its `rate_hz` must be the first's (both sample on the simulator's tick).
    pub imu2: Option<ImuParams>,
    /// `[sensors.gps]`
    pub gps: GpsParams,
    /// `[sensors.baro]`
    pub baro: BaroParams,
    /// `[sensors.mag]`
    pub mag: MagParams,
    /// `[sensors.rangefinder_up]`: a single-beam rangefinder looking out of the top (what is
    /// overhead), published on `rangefinder_up`; absent on an airframe without one.
    pub rangefinder_up: Option<RangefinderParams>,
    /// `[sensors.rangefinder_down]`: one looking out of the bottom (height over the ground or
    /// whatever stands below), published on `rangefinder_down`; absent without one.
    pub rangefinder_down: Option<RangefinderParams>,
}

impl SensorParams {
    pub(crate) fn validate(&self) -> Result<(), InvalidParam> {
        finite("board_rotation_deg", &self.board_rotation_deg)?;
        if self.board_rotation_deg.iter().any(|a| a.abs() > 180.0) {
            return Err(InvalidParam::new("board_rotation_deg", "angles must lie within ±180°"));
        }
        self.imu.validate().map_err(|e| e.within("imu"))?;
        if let Some(imu2) = &self.imu2 {
            imu2.validate().map_err(|e| e.within("imu2"))?;
            if imu2.rate_hz != self.imu.rate_hz {
                return Err(InvalidParam::new(
                    "imu2.rate_hz",
                    format!(
                        "must equal imu.rate_hz ({} Hz): both sample on the simulator's tick",
                        self.imu.rate_hz
                    ),
                ));
            }
        }
        self.gps.validate().map_err(|e| e.within("gps"))?;
        self.baro.validate().map_err(|e| e.within("baro"))?;
        self.mag.validate().map_err(|e| e.within("mag"))?;
        if let Some(up) = &self.rangefinder_up {
            up.validate().map_err(|e| e.within("rangefinder_up"))?;
        }
        if let Some(down) = &self.rangefinder_down {
            down.validate().map_err(|e| e.within("rangefinder_down"))?;
        }
        Ok(())
    }

    /// Board → airframe, `None` for a board aligned with the airframe (so the default path does
    /// no arithmetic it did not do before).
    pub(crate) fn board_rotation(&self) -> Option<UnitQuaternion<f64>> {
        let [roll, pitch, yaw] = self.board_rotation_deg.map(f64::to_radians);
        (self.board_rotation_deg != [0.0; 3]).then(|| UnitQuaternion::from_euler_angles(roll, pitch, yaw))
    }
}
