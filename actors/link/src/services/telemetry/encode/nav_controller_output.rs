//! NAV_CONTROLLER_OUTPUT: what the position controller is steering to, from the commander's
//! setpoint and the estimate, as ArduCopter's `send_nav_controller_output` fills it: the attitude
//! asked for (deg), the heading asked for and the bearing to the position target (deg), the
//! horizontal distance to it (m), the height error (target above the vehicle positive, m) and
//! the cross-track error (`AC_PosControl::crosstrack_error`: the distance from the target across
//! the desired velocity, or to it when there is none; m). Without a position target the bearing,
//! distance and errors read 0, as ArduCopter's velocity and attitude submodes report them.
//! The attitude asked for is the setpoint's in STABILIZE and GUIDED's attitude targets; while a
//! trajectory is flown the tilt is chosen inside the control loop, so the estimated one (which
//! the loop holds to the demand) is sent.

use kestrel_proto::attitude::euler_rad;
use kestrel_proto::messages::SetpointTarget;
use mavlink::dialects::ardupilotmega::NAV_CONTROLLER_OUTPUT_DATA;

use super::super::Snapshot;

/// A bearing (rad) in whole degrees, -180..180 as ArduCopter's centidegrees / 100.
fn degrees(rad: f64) -> i16 {
    let deg = rad.to_degrees();
    (deg + 180.0).rem_euclid(360.0).round() as i16 - 180
}

/// NAV_CONTROLLER_OUTPUT from the newest setpoint and estimate (`None` without an estimate).
pub fn nav_controller_output(snap: &Snapshot) -> Option<NAV_CONTROLLER_OUTPUT_DATA> {
    let nav = snap.nav.as_ref()?;
    let [roll, pitch, yaw] = euler_rad(nav.attitude);
    let mut out = NAV_CONTROLLER_OUTPUT_DATA {
        nav_roll: roll.to_degrees() as f32,
        nav_pitch: pitch.to_degrees() as f32,
        nav_bearing: degrees(yaw),
        ..NAV_CONTROLLER_OUTPUT_DATA::DEFAULT
    };
    match snap.setpoint.as_ref().filter(|s| s.armed).map(|s| &s.target) {
        Some(SetpointTarget::Attitude { attitude, .. }) => {
            let [r, p, y] = euler_rad(*attitude);
            out.nav_roll = r.to_degrees() as f32;
            out.nav_pitch = p.to_degrees() as f32;
            out.nav_bearing = degrees(y);
        }
        Some(SetpointTarget::Trajectory(t)) => {
            if let Some(yaw) = t.yaw_rad {
                out.nav_bearing = degrees(yaw);
            }
            let p = nav.position_ned_m;
            if let [Some(n), Some(e), _] = t.position_ned_m {
                let (dn, de) = (n - p[0], e - p[1]);
                out.target_bearing = degrees(de.atan2(dn));
                out.wp_dist = dn.hypot(de).round().min(f64::from(u16::MAX)) as u16;
                let [vn, ve] = [t.velocity_ned_m_s[0].unwrap_or(0.0), t.velocity_ned_m_s[1].unwrap_or(0.0)];
                let speed = vn.hypot(ve);
                let xtrack = if speed == 0.0 {
                    dn.hypot(de)
                } else {
                    let along = (dn * vn + de * ve) / speed;
                    (dn * dn + de * de - along * along).max(0.0).sqrt()
                };
                out.xtrack_error = xtrack as f32;
            }
            if let Some(d) = t.position_ned_m[2] {
                out.alt_error = (p[2] - d) as f32;
            }
        }
        Some(SetpointTarget::Rates { .. } | SetpointTarget::MotorsOff) | None => {}
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::{FlightMode, TrajectorySetpoint};

    use super::*;
    use crate::services::telemetry::encode::position_target_local_ned::tests::flying;

    #[test]
    fn bearing_distance_and_errors_are_to_the_position_target() {
        // The vehicle is 10 m north of the origin, 30 m up, facing east.
        let t = TrajectorySetpoint {
            position_ned_m: [Some(10.0), Some(20.0), Some(-35.0)],
            velocity_ned_m_s: [Some(1.0), Some(0.0), None],
            yaw_rad: Some(-std::f64::consts::FRAC_PI_2),
            ..TrajectorySetpoint::default()
        };
        let m =
            nav_controller_output(&flying(FlightMode::Guided, SetpointTarget::Trajectory(t))).expect("sent");
        assert_eq!((m.nav_bearing, m.target_bearing, m.wp_dist), (-90, 90, 20), "{m:?}");
        assert!((m.alt_error - 5.0).abs() < 1e-6, "5 m below the target: {}", m.alt_error);
        assert!((m.xtrack_error - 20.0).abs() < 1e-6, "20 m east of a northward track");
        let still = TrajectorySetpoint {
            velocity_ned_m_s: [None; 3],
            position_ned_m: [Some(13.0), Some(4.0), None],
            ..t
        };
        let m = nav_controller_output(&flying(FlightMode::Guided, SetpointTarget::Trajectory(still)))
            .expect("sent");
        assert!((m.xtrack_error - 5.0).abs() < 1e-6, "no velocity: the distance, 3-4-5");
        assert_eq!((m.wp_dist, m.alt_error), (5, 0.0));
        let velocity = TrajectorySetpoint { position_ned_m: [None; 3], ..t };
        let m = nav_controller_output(&flying(FlightMode::Guided, SetpointTarget::Trajectory(velocity)))
            .expect("sent");
        assert_eq!(
            (m.wp_dist, m.target_bearing, m.xtrack_error),
            (0, 0, 0.0),
            "no position: nothing to steer to"
        );
        let level_east = SetpointTarget::Attitude {
            attitude: [(std::f64::consts::FRAC_PI_4).cos(), 0.0, 0.0, (std::f64::consts::FRAC_PI_4).sin()],
            yaw_rate_rad_s: 0.0,
            thrust: 0.5,
        };
        let m = nav_controller_output(&flying(FlightMode::Stabilize, level_east)).expect("sent");
        assert_eq!(m.nav_bearing, 90);
    }
}
