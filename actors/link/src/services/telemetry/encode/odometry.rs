//! ODOMETRY: the estimator's pose and velocity in one message (PX4 streams it, MAVSDK's
//! `odometry` reads it); ArduCopter does not send it.

use kestrel_proto::attitude::unit_quaternion;
use kestrel_proto::messages::NavState;
use mavlink::dialects::ardupilotmega::{MavEstimatorType, MavFrame, ODOMETRY_DATA};
use nalgebra::Vector3;

/// ODOMETRY from `nav`: position (m) in the estimator's local NED frame, the body-to-NED
/// quaternion, velocity in the body frame (m/s, FRD: `child_frame_id`, as the message defines
/// it) and body rates (rad/s). Covariances unknown (NaN first element, as the message says);
/// `None` for an attitude that is no rotation.
pub fn odometry(nav: &NavState) -> Option<ODOMETRY_DATA> {
    let q = unit_quaternion(nav.attitude).ok()?;
    let [x, y, z] = nav.position_ned_m.map(|v| v as f32);
    let v_body = q.inverse() * Vector3::from(nav.velocity_ned_m_s);
    let [rollspeed, pitchspeed, yawspeed] = nav.angular_velocity_rad_s.map(|v| v as f32);
    let mut unknown = [0.0; 21];
    unknown[0] = f32::NAN;
    Some(ODOMETRY_DATA {
        time_usec: nav.time.as_micros(),
        x,
        y,
        z,
        q: [q.w as f32, q.i as f32, q.j as f32, q.k as f32],
        vx: v_body.x as f32,
        vy: v_body.y as f32,
        vz: v_body.z as f32,
        rollspeed,
        pitchspeed,
        yawspeed,
        pose_covariance: unknown,
        velocity_covariance: unknown,
        frame_id: MavFrame::MAV_FRAME_LOCAL_NED,
        child_frame_id: MavFrame::MAV_FRAME_BODY_FRD,
        reset_counter: 0,
        estimator_type: MavEstimatorType::MAV_ESTIMATOR_TYPE_AUTOPILOT,
        // 0: quality unknown (−1 would say the estimate failed).
        quality: 0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::services::telemetry::encode::nav_facing_east;

    #[test]
    fn facing_east_a_northward_velocity_is_to_the_left_of_the_body() {
        let o = odometry(&nav_facing_east()).expect("a rotation");
        assert_eq!((o.x, o.y, o.z), (10.0, 0.0, -30.0));
        // 1 m/s north and 0.5 m/s up, seen from a vehicle facing east: left and up.
        assert!(o.vx.abs() < 1e-6 && (o.vy + 1.0).abs() < 1e-6 && (o.vz + 0.5).abs() < 1e-6, "{o:?}");
        assert!(o.pose_covariance[0].is_nan() && o.velocity_covariance[0].is_nan());
        assert_eq!(
            (o.frame_id, o.child_frame_id),
            (MavFrame::MAV_FRAME_LOCAL_NED, MavFrame::MAV_FRAME_BODY_FRD)
        );
    }
}
