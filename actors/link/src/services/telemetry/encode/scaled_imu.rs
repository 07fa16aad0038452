//! SCALED_IMU: the first IMU in milli-g and mrad/s (ArduPilot sends it on request only).

use kestrel_proto::messages::ImuSample;
use mavlink::dialects::ardupilotmega::SCALED_IMU_DATA;

use super::imu_units::imu_mg_mrad_s;

/// SCALED_IMU from the IMU's newest sample, stamped with its measurement time (ms since boot).
pub fn scaled_imu(imu: &ImuSample) -> SCALED_IMU_DATA {
    let [xacc, yacc, zacc, xgyro, ygyro, zgyro] = imu_mg_mrad_s(imu);
    SCALED_IMU_DATA {
        time_boot_ms: (imu.time.as_micros() / 1000) as u32,
        xacc,
        yacc,
        zacc,
        xgyro,
        ygyro,
        zgyro,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;

    use super::*;

    #[test]
    fn scaled_imu_is_stamped_in_milliseconds() {
        let s = scaled_imu(&ImuSample {
            time: Time::from_micros(1_234_567),
            accel_m_s2: [0.0, 0.0, -9.80665],
            ..crate::services::telemetry::encode::imu_at_rest()
        });
        assert_eq!((s.time_boot_ms, s.zacc), (1234, -1000));
    }
}
