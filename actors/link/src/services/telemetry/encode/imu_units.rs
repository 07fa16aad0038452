//! The IMU in the integer units of RAW_IMU and SCALED_IMU, as ArduPilot scales both
//! (`GCS_MAVLINK::send_raw_imu`, `send_scaled_imu`): acceleration in milli-g, rates in mrad/s.

use kestrel_proto::messages::ImuSample;
use kestrel_proto::units::GRAVITY_M_S2;

/// `[ax, ay, az, gx, gy, gz]`: specific force (mG, body FRD) and rates (mrad/s), saturated to
/// i16 (±32 g, ±32 rad/s: beyond any sensor we read).
pub fn imu_mg_mrad_s(imu: &ImuSample) -> [i16; 6] {
    let sat = |v: f64| v.round().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16;
    let [ax, ay, az] = imu.accel_m_s2.map(|a| sat(a * 1000.0 / GRAVITY_M_S2));
    let [gx, gy, gz] = imu.gyro_rad_s.map(|g| sat(g * 1000.0));
    [ax, ay, az, gx, gy, gz]
}
