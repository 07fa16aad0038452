//! ATTITUDE_QUATERNION: the estimator's attitude as the body-to-NED quaternion (w, x, y, z),
//! unit length, and its body rates (rad/s, FRD) — what MAVSDK's `attitude_quaternion` reads.

use kestrel_proto::attitude::unit_quaternion;
use kestrel_proto::messages::NavState;
use mavlink::dialects::ardupilotmega::ATTITUDE_QUATERNION_DATA;

/// ATTITUDE_QUATERNION from `nav`, stamped `boot_ms` (ms since boot); `None` for an attitude
/// that is no rotation (a zero quaternion, NaN), which no ground station could draw.
pub fn attitude_quaternion(nav: &NavState, boot_ms: u32) -> Option<ATTITUDE_QUATERNION_DATA> {
    let q = unit_quaternion(nav.attitude).ok()?;
    let [p, r, y] = nav.angular_velocity_rad_s.map(|v| v as f32);
    Some(ATTITUDE_QUATERNION_DATA {
        time_boot_ms: boot_ms,
        q1: q.w as f32,
        q2: q.i as f32,
        q3: q.j as f32,
        q4: q.k as f32,
        rollspeed: p,
        pitchspeed: r,
        yawspeed: y,
        // No offset: the quaternion is the vehicle's own attitude.
        repr_offset_q: [0.0; 4],
    })
}

#[cfg(test)]
mod tests {
    use kestrel_proto::attitude::euler_rad;

    use super::*;
    use crate::services::telemetry::encode::attitude::attitude;
    use crate::services::telemetry::encode::nav_facing_east;

    #[test]
    fn the_quaternion_is_unit_length_and_says_what_attitude_says() {
        let mut nav = nav_facing_east();
        nav.attitude = kestrel_proto::attitude::quaternion_from_euler(0.1, -0.2, 2.5);
        nav.angular_velocity_rad_s = [0.1, 0.2, -0.3];
        let q = attitude_quaternion(&nav, 40).expect("a rotation");
        let euler = euler_rad([q.q1, q.q2, q.q3, q.q4].map(f64::from));
        let a = attitude(&nav, 40);
        for (from_q, from_a) in euler.iter().zip([a.roll, a.pitch, a.yaw]) {
            assert!((from_q - f64::from(from_a)).abs() < 1e-6, "{q:?} {a:?}");
        }
        assert_eq!((q.rollspeed, q.pitchspeed, q.yawspeed, q.time_boot_ms), (0.1, 0.2, -0.3, 40));
        // A long quaternion goes out normalised.
        nav.attitude = nav.attitude.map(|v| v * 1.01);
        let q = attitude_quaternion(&nav, 40).expect("a rotation");
        let norm = (q.q1 * q.q1 + q.q2 * q.q2 + q.q3 * q.q3 + q.q4 * q.q4).sqrt();
        assert!((norm - 1.0).abs() < 1e-6, "{q:?}");
        nav.attitude = [0.0; 4];
        assert!(attitude_quaternion(&nav, 0).is_none());
    }
}
