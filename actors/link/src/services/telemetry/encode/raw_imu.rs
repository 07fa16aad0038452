//! RAW_IMU: the first IMU as ArduPilot streams it (RAW_SENSORS group), in its scaled units.

use kestrel_proto::messages::ImuSample;
use mavlink::dialects::ardupilotmega::RAW_IMU_DATA;

use super::imu_units::imu_mg_mrad_s;

/// RAW_IMU from the IMU's newest sample: specific force (mG) and rates (mrad/s), body FRD, as
/// ArduPilot fills it; no magnetometer in the sample (0) and no temperature (0, "not sent").
pub fn raw_imu(imu: &ImuSample) -> RAW_IMU_DATA {
    let [xacc, yacc, zacc, xgyro, ygyro, zgyro] = imu_mg_mrad_s(imu);
    RAW_IMU_DATA {
        time_usec: imu.time.as_micros(),
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
    use kestrel_proto::units::GRAVITY_M_S2;

    use super::*;

    #[test]
    fn at_rest_the_down_axis_reads_minus_one_g_in_milli_g() {
        let imu = ImuSample {
            time: Time::from_micros(7),
            gyro_rad_s: [0.002, -0.5, 40.0],
            accel_m_s2: [0.0, 0.0, -GRAVITY_M_S2],
            ..crate::services::telemetry::encode::imu_at_rest()
        };
        let r = raw_imu(&imu);
        assert_eq!((r.xacc, r.yacc, r.zacc), (0, 0, -1000));
        assert_eq!((r.xgyro, r.ygyro, r.zgyro), (2, -500, i16::MAX), "mrad/s, saturated");
        assert_eq!(r.time_usec, 7);
    }
}
