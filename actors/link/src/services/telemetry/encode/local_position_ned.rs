//! LOCAL_POSITION_NED: the estimator's position (m) and velocity (m/s) in its NED frame.

use kestrel_proto::messages::NavState;
use mavlink::dialects::ardupilotmega::LOCAL_POSITION_NED_DATA;

/// LOCAL_POSITION_NED from `nav`, stamped `boot_ms` (ms since boot).
pub fn local_position_ned(nav: &NavState, boot_ms: u32) -> LOCAL_POSITION_NED_DATA {
    let [x, y, z] = nav.position_ned_m.map(|v| v as f32);
    let [vx, vy, vz] = nav.velocity_ned_m_s.map(|v| v as f32);
    LOCAL_POSITION_NED_DATA { time_boot_ms: boot_ms, x, y, z, vx, vy, vz }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::services::telemetry::encode::nav_facing_east;

    #[test]
    fn position_and_velocity_are_the_estimators_in_metres_down_positive() {
        let l = local_position_ned(&nav_facing_east(), 7);
        assert_eq!((l.x, l.y, l.z), (10.0, 0.0, -30.0));
        assert_eq!((l.vx, l.vy, l.vz, l.time_boot_ms), (1.0, 0.0, -0.5, 7));
    }
}
