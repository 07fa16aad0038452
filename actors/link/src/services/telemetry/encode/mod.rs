//! How each telemetry message is filled from the graph's latest state: one file per message,
//! each a function from the [`Snapshot`] (or the part of it the message needs) to the message,
//! in MAVLink's units. `None` when the graph has not said enough yet: nothing is sent rather
//! than a made-up value. Quaternion → Euler happens here for display only.

use kestrel_proto::Time;
use kestrel_proto::attitude::euler_rad;
use mavlink::MessageData;
use mavlink::dialects::ardupilotmega::{
    ATTITUDE_DATA, ATTITUDE_QUATERNION_DATA, BATTERY_STATUS_DATA, DEBUG_VECT_DATA, DISTANCE_SENSOR_DATA,
    EKF_STATUS_REPORT_DATA, EXTENDED_SYS_STATE_DATA, FENCE_STATUS_DATA, GLOBAL_POSITION_INT_DATA,
    GPS_RAW_INT_DATA, HIGHRES_IMU_DATA, HOME_POSITION_DATA, LOCAL_POSITION_NED_DATA, MISSION_CURRENT_DATA,
    MavMessage, NAV_CONTROLLER_OUTPUT_DATA, OBSTACLE_DISTANCE_DATA, ODOMETRY_DATA,
    POSITION_TARGET_GLOBAL_INT_DATA, POSITION_TARGET_LOCAL_NED_DATA, RAW_IMU_DATA, RC_CHANNELS_DATA,
    SCALED_IMU_DATA, SCALED_PRESSURE_DATA, SERVO_OUTPUT_RAW_DATA, SIMSTATE_DATA, SYS_STATUS_DATA,
    SYSTEM_TIME_DATA, VFR_HUD_DATA, WIND_DATA,
};

use super::Snapshot;

pub mod attitude;
pub mod attitude_quaternion;
pub mod battery_status;
pub mod debug_vect;
pub mod distance_sensor;
pub mod ekf_status_report;
pub mod extended_sys_state;
pub mod fence_status;
pub mod global_position_int;
pub mod gps_raw_int;
pub mod highres_imu;
pub mod home_position;
mod imu_units;
pub mod local_position_ned;
pub mod mission_current;
pub mod nav_controller_output;
pub mod obstacle_distance;
pub mod odometry;
pub mod position_target_global_int;
pub mod position_target_local_ned;
pub mod raw_imu;
pub mod rc_channels;
pub mod scaled_imu;
pub mod scaled_pressure;
pub mod servo_output_raw;
pub mod simstate;
pub mod sys_status;
pub mod system_time;
pub mod vfr_hud;
pub mod wind;

/// Message `id` from the latest state at `now` (`None`: not ours, or nothing known yet).
pub fn build(snap: &Snapshot, id: u32, now: Time) -> Option<MavMessage> {
    let boot_ms = (now.as_micros() / 1000) as u32;
    Some(match id {
        SYS_STATUS_DATA::ID => MavMessage::SYS_STATUS(sys_status::sys_status(snap)),
        EKF_STATUS_REPORT_DATA::ID => MavMessage::EKF_STATUS_REPORT(ekf_status_report::ekf_status(
            snap.nav.as_ref()?,
            snap.estimator.as_ref(),
        )),
        ATTITUDE_DATA::ID => MavMessage::ATTITUDE(attitude::attitude(snap.nav.as_ref()?, boot_ms)),
        SIMSTATE_DATA::ID => MavMessage::SIMSTATE(simstate::simstate(snap.truth.as_ref()?)?),
        // Asked for once (MAV_CMD_REQUEST_MESSAGE): the first fresh one, down before up.
        DISTANCE_SENSOR_DATA::ID => distance_sensor::fresh(snap, now).next()?,
        WIND_DATA::ID => MavMessage::WIND(wind::wind(snap.estimator.as_ref()?.wind_ne_m_s?)),
        LOCAL_POSITION_NED_DATA::ID => MavMessage::LOCAL_POSITION_NED(
            local_position_ned::local_position_ned(snap.nav.as_ref()?, boot_ms),
        ),
        GLOBAL_POSITION_INT_DATA::ID => MavMessage::GLOBAL_POSITION_INT(
            global_position_int::global_position_int(snap.nav.as_ref()?, boot_ms)?,
        ),
        GPS_RAW_INT_DATA::ID => MavMessage::GPS_RAW_INT(gps_raw_int::gps_raw(snap.gps.as_ref()?)),
        VFR_HUD_DATA::ID => MavMessage::VFR_HUD(vfr_hud::vfr_hud(snap.nav.as_ref()?)),
        BATTERY_STATUS_DATA::ID => {
            MavMessage::BATTERY_STATUS(battery_status::battery_status(snap.battery.as_ref()?))
        }
        HOME_POSITION_DATA::ID => MavMessage::HOME_POSITION(home_position::home_position(snap, now)?),
        EXTENDED_SYS_STATE_DATA::ID => {
            MavMessage::EXTENDED_SYS_STATE(extended_sys_state::extended_sys_state(snap.status.as_ref()?))
        }
        MISSION_CURRENT_DATA::ID => MavMessage::MISSION_CURRENT(mission_current::mission_current(snap)),
        FENCE_STATUS_DATA::ID => MavMessage::FENCE_STATUS(fence_status::fence_status(snap.status.as_ref()?)?),
        OBSTACLE_DISTANCE_DATA::ID => {
            let depth = snap.depth.as_ref()?;
            MavMessage::OBSTACLE_DISTANCE(obstacle_distance::obstacle_distance(depth.time, &depth.sectors))
        }
        DEBUG_VECT_DATA::ID => MavMessage::DEBUG_VECT(debug_vect::debug_vect(snap.avoidance.as_ref()?)),
        ATTITUDE_QUATERNION_DATA::ID => MavMessage::ATTITUDE_QUATERNION(
            attitude_quaternion::attitude_quaternion(snap.nav.as_ref()?, boot_ms)?,
        ),
        ODOMETRY_DATA::ID => MavMessage::ODOMETRY(odometry::odometry(snap.nav.as_ref()?)?),
        SYSTEM_TIME_DATA::ID => MavMessage::SYSTEM_TIME(system_time::system_time(boot_ms)),
        SCALED_PRESSURE_DATA::ID => {
            MavMessage::SCALED_PRESSURE(scaled_pressure::scaled_pressure(snap.baro.as_ref()?))
        }
        RAW_IMU_DATA::ID => MavMessage::RAW_IMU(raw_imu::raw_imu(snap.imu.as_ref()?)),
        SCALED_IMU_DATA::ID => MavMessage::SCALED_IMU(scaled_imu::scaled_imu(snap.imu.as_ref()?)),
        HIGHRES_IMU_DATA::ID => MavMessage::HIGHRES_IMU(highres_imu::highres_imu(snap.imu.as_ref()?)),
        SERVO_OUTPUT_RAW_DATA::ID => MavMessage::SERVO_OUTPUT_RAW(servo_output_raw::servo_output_raw(
            snap.actuators.as_ref()?,
            snap.esc_pulses.as_ref(),
        )),
        RC_CHANNELS_DATA::ID => {
            MavMessage::RC_CHANNELS(rc_channels::rc_channels(snap.sticks.as_ref()?, now, boot_ms)?)
        }
        NAV_CONTROLLER_OUTPUT_DATA::ID => {
            MavMessage::NAV_CONTROLLER_OUTPUT(nav_controller_output::nav_controller_output(snap)?)
        }
        POSITION_TARGET_LOCAL_NED_DATA::ID => MavMessage::POSITION_TARGET_LOCAL_NED(
            position_target_local_ned::position_target_local_ned(snap, boot_ms)?,
        ),
        POSITION_TARGET_GLOBAL_INT_DATA::ID => MavMessage::POSITION_TARGET_GLOBAL_INT(
            position_target_global_int::position_target_global_int(snap, boot_ms)?,
        ),
        _ => return None,
    })
}

/// The heading of attitude `q` in centidegrees clockwise from north, 0..36000.
pub fn heading_cdeg(q: [f64; 4]) -> u16 {
    let yaw_deg = euler_rad(q)[2].to_degrees().rem_euclid(360.0);
    ((yaw_deg * 100.0).round() as u16) % 36_000
}

/// A state the encoders' tests share: facing east, 30 m up, 10 m north of an origin at 20 m.
#[cfg(test)]
pub(crate) fn nav_facing_east() -> kestrel_proto::messages::NavState {
    use kestrel_proto::geo::Geodetic;
    use kestrel_proto::messages::{NavState, NavValidity};
    let half = (std::f64::consts::FRAC_PI_2 / 2.0, 0.0);
    NavState {
        time: Time::ZERO,
        attitude: [half.0.cos(), 0.0, 0.0, half.0.sin()],
        angular_velocity_rad_s: [0.0; 3],
        velocity_ned_m_s: [1.0, 0.0, -0.5],
        position_ned_m: [10.0, 0.0, -30.0],
        gyro_bias_rad_s: [0.0; 3],
        accel_bias_m_s2: [0.0; 3],
        covariance_diagonal: [0.0; 16],
        origin: Some(Geodetic { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 20.0 }),
        valid: NavValidity { attitude: true, ..Default::default() },
    }
}

/// An IMU sample at rest, level, at time zero: the IMU encoders' tests set what they need.
#[cfg(test)]
pub(crate) fn imu_at_rest() -> kestrel_proto::messages::ImuSample {
    kestrel_proto::messages::ImuSample {
        time: Time::ZERO,
        gyro_rad_s: [0.0; 3],
        accel_m_s2: [0.0, 0.0, -kestrel_proto::units::GRAVITY_M_S2],
        dt_s: 0.0025,
        gyro_clipped: [false; 3],
        accel_clipped: [false; 3],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headings_wrap_into_0_to_36000_centidegrees() {
        let yaw = |deg: f64| {
            let half = deg.to_radians() / 2.0;
            [half.cos(), 0.0, 0.0, half.sin()]
        };
        assert_eq!(heading_cdeg(yaw(90.0)), 9_000);
        assert_eq!(heading_cdeg(yaw(-90.0)), 27_000);
        assert_eq!(heading_cdeg(yaw(359.999)), 0);
    }

    #[test]
    fn messages_we_do_not_stream_are_not_built() {
        let snap = Snapshot { nav: Some(nav_facing_east()), ..Snapshot::default() };
        assert!(build(&snap, mavlink::dialects::ardupilotmega::HEARTBEAT_DATA::ID, Time::ZERO).is_none());
    }
}
