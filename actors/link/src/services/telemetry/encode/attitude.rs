//! ATTITUDE: the estimator's attitude as roll, pitch, yaw (rad, display only) and its body
//! rates (rad/s, FRD).

use kestrel_proto::attitude::euler_rad;
use kestrel_proto::messages::NavState;
use mavlink::dialects::ardupilotmega::ATTITUDE_DATA;

/// ATTITUDE from `nav`, stamped `boot_ms` (ms since boot).
pub fn attitude(nav: &NavState, boot_ms: u32) -> ATTITUDE_DATA {
    let [roll, pitch, yaw] = euler_rad(nav.attitude);
    let [p, q, r] = nav.angular_velocity_rad_s;
    ATTITUDE_DATA {
        time_boot_ms: boot_ms,
        roll: roll as f32,
        pitch: pitch as f32,
        yaw: yaw as f32,
        rollspeed: p as f32,
        pitchspeed: q as f32,
        yawspeed: r as f32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::services::telemetry::encode::nav_facing_east;

    #[test]
    fn facing_east_is_a_yaw_of_a_quarter_turn_and_rates_pass_through() {
        let mut nav = nav_facing_east();
        nav.angular_velocity_rad_s = [0.1, -0.2, 0.3];
        let a = attitude(&nav, 1234);
        assert!((f64::from(a.yaw) - std::f64::consts::FRAC_PI_2).abs() < 1e-6, "{a:?}");
        assert!(a.roll.abs() < 1e-6 && a.pitch.abs() < 1e-6, "{a:?}");
        assert_eq!((a.rollspeed, a.pitchspeed, a.yawspeed, a.time_boot_ms), (0.1, -0.2, 0.3, 1234));
    }
}
