//! SYS_STATUS: which sensors and subsystems are present, enabled and healthy, and the battery.

use kestrel_proto::messages::FailsafeCause;
use mavlink::dialects::ardupilotmega::{MavSysStatusSensor, SYS_STATUS_DATA};

use super::super::Snapshot;

/// SYS_STATUS as ArduPilot reports it: the IMU, compass and AHRS healthy once the attitude
/// estimate is, the barometer and GPS once their parts of the position are, the battery once
/// reported, the depth camera once a grid came, and the pre-arm bit while the commander's pre-arm
/// checks pass (MAVSDK's `is_armable`), and the motor outputs unhealthy once a motor was
/// declared failed.
pub fn sys_status(snap: &Snapshot) -> SYS_STATUS_DATA {
    type S = MavSysStatusSensor;
    let mut present = S::MAV_SYS_STATUS_SENSOR_3D_GYRO
        | S::MAV_SYS_STATUS_SENSOR_3D_ACCEL
        | S::MAV_SYS_STATUS_SENSOR_3D_MAG
        | S::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
        | S::MAV_SYS_STATUS_SENSOR_GPS
        | S::MAV_SYS_STATUS_AHRS
        | S::MAV_SYS_STATUS_PREARM_CHECK;
    let mut health = S::empty();
    if let Some(v) = snap.nav.as_ref().map(|n| n.valid) {
        if v.attitude {
            health |= S::MAV_SYS_STATUS_SENSOR_3D_GYRO
                | S::MAV_SYS_STATUS_SENSOR_3D_ACCEL
                | S::MAV_SYS_STATUS_SENSOR_3D_MAG
                | S::MAV_SYS_STATUS_AHRS;
        }
        if v.vertical_position {
            health |= S::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE;
        }
        if v.horizontal_position {
            health |= S::MAV_SYS_STATUS_SENSOR_GPS;
        }
    }
    if snap.battery.is_some() {
        present |= S::MAV_SYS_STATUS_SENSOR_BATTERY;
        health |= S::MAV_SYS_STATUS_SENSOR_BATTERY;
    }
    if snap.depth.is_some() {
        present |= S::MAV_SYS_STATUS_SENSOR_PROXIMITY;
        health |= S::MAV_SYS_STATUS_SENSOR_PROXIMITY;
    }
    if snap.status.as_ref().is_some_and(|s| s.armable || s.armed) {
        health |= S::MAV_SYS_STATUS_PREARM_CHECK;
    }
    // The geofence: enabled as switched, healthy unless breached (MAVProxy says "fence
    // breach" when the bit is present and enabled but not healthy).
    present |= S::MAV_SYS_STATUS_GEOFENCE | S::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS;
    if snap.status.as_ref().is_none_or(|s| s.failed_motor.is_none()) {
        health |= S::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS;
    }
    let mut enabled = present;
    if let Some(s) = &snap.status {
        if !s.geofence_enabled {
            enabled.remove(S::MAV_SYS_STATUS_GEOFENCE);
        }
        if s.failsafe.is_none_or(|f| f.cause != FailsafeCause::GeofenceBreach) {
            health |= S::MAV_SYS_STATUS_GEOFENCE;
        }
    }
    let (voltage, current, remaining) = snap.battery.as_ref().map_or((u16::MAX, -1, -1), |b| {
        (
            (b.voltage_v * 1000.0).clamp(0.0, 65_534.0) as u16,
            (b.current_a * 100.0).round() as i16,
            (b.remaining * 100.0).round().clamp(0.0, 100.0) as i8,
        )
    });
    SYS_STATUS_DATA {
        onboard_control_sensors_present: present,
        onboard_control_sensors_enabled: enabled,
        onboard_control_sensors_health: health,
        voltage_battery: voltage,
        current_battery: current,
        battery_remaining: remaining,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::messages::{FlightMode, LandedState, VehicleStatus};
    use kestrel_proto::testing::vehicle_status;

    use super::*;
    use crate::services::telemetry::encode::nav_facing_east;

    type S = MavSysStatusSensor;

    #[test]
    fn sys_status_shows_the_motor_outputs_unhealthy_once_a_motor_failed() {
        let mut snap = Snapshot::default();
        let status = |failed_motor| VehicleStatus {
            failed_motor,
            ..vehicle_status(Time::ZERO, true, FlightMode::Auto, LandedState::InAir)
        };
        let motors = S::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS;
        snap.status = Some(status(None));
        let healthy = sys_status(&snap);
        assert!(healthy.onboard_control_sensors_present.contains(motors));
        assert!(healthy.onboard_control_sensors_health.contains(motors));
        snap.status = Some(status(Some(2)));
        assert!(!sys_status(&snap).onboard_control_sensors_health.contains(motors));
    }

    #[test]
    fn an_attitude_makes_the_imu_healthy_and_no_battery_reads_unknown() {
        let snap = Snapshot { nav: Some(nav_facing_east()), ..Snapshot::default() };
        let s = sys_status(&snap);
        assert!(
            s.onboard_control_sensors_health
                .contains(S::MAV_SYS_STATUS_SENSOR_3D_GYRO | S::MAV_SYS_STATUS_AHRS)
        );
        assert!(!s.onboard_control_sensors_health.contains(S::MAV_SYS_STATUS_SENSOR_GPS), "no position yet");
        assert!(!s.onboard_control_sensors_present.contains(S::MAV_SYS_STATUS_SENSOR_BATTERY));
        assert_eq!((s.voltage_battery, s.current_battery, s.battery_remaining), (u16::MAX, -1, -1));
    }
}
