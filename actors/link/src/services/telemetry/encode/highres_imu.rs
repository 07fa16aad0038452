//! HIGHRES_IMU: the first IMU in SI units (m/s², rad/s), as ArduPilot sends it on request.

use kestrel_proto::messages::ImuSample;
use mavlink::dialects::ardupilotmega::{HIGHRES_IMU_DATA, HighresImuUpdatedFlags};

/// HIGHRES_IMU from the IMU's newest sample; `fields_updated` names the six IMU fields only
/// (the sample carries no magnetometer, pressure or temperature).
pub fn highres_imu(imu: &ImuSample) -> HIGHRES_IMU_DATA {
    type F = HighresImuUpdatedFlags;
    let [xacc, yacc, zacc] = imu.accel_m_s2.map(|v| v as f32);
    let [xgyro, ygyro, zgyro] = imu.gyro_rad_s.map(|v| v as f32);
    HIGHRES_IMU_DATA {
        time_usec: imu.time.as_micros(),
        xacc,
        yacc,
        zacc,
        xgyro,
        ygyro,
        zgyro,
        fields_updated: F::HIGHRES_IMU_UPDATED_XACC
            | F::HIGHRES_IMU_UPDATED_YACC
            | F::HIGHRES_IMU_UPDATED_ZACC
            | F::HIGHRES_IMU_UPDATED_XGYRO
            | F::HIGHRES_IMU_UPDATED_YGYRO
            | F::HIGHRES_IMU_UPDATED_ZGYRO,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;

    use super::*;

    #[test]
    fn highres_imu_is_in_si_units_and_flags_only_what_it_fills() {
        let h = highres_imu(&ImuSample {
            time: Time::from_micros(9),
            gyro_rad_s: [0.1, 0.0, 0.0],
            accel_m_s2: [0.0, 0.0, -9.8],
            ..crate::services::telemetry::encode::imu_at_rest()
        });
        assert_eq!((h.xgyro, h.zacc, h.time_usec), (0.1, -9.8, 9));
        assert_eq!(h.fields_updated.bits(), 0x3f);
    }
}
