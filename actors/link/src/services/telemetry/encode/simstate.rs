//! SIMSTATE: the simulator's truth, as ArduPilot SITL sends it (never on hardware).

use kestrel_proto::attitude::{euler_rad, unit_quaternion};
use kestrel_proto::geo::deg_e7;
use kestrel_proto::messages::GroundTruth;
use kestrel_proto::units::GRAVITY_M_S2;
use mavlink::dialects::ardupilotmega::SIMSTATE_DATA;
use nalgebra::Vector3;

/// ArduPilot SITL's SIMSTATE from the simulator's truth: the true attitude (rad), what an ideal
/// accelerometer would read (m/s², body FRD, gravity included) and the true rates (rad/s,
/// body), and the true position. `None` for a truth without a valid attitude.
pub fn simstate(truth: &GroundTruth) -> Option<SIMSTATE_DATA> {
    let attitude = unit_quaternion(truth.attitude).ok()?;
    let [roll, pitch, yaw] = euler_rad(truth.attitude);
    let gravity_ned = Vector3::new(0.0, 0.0, GRAVITY_M_S2);
    let specific_force = attitude.inverse() * (Vector3::from(truth.acceleration_ned_m_s2) - gravity_ned);
    let [p, q, r] = truth.angular_velocity_rad_s;
    Some(SIMSTATE_DATA {
        roll: roll as f32,
        pitch: pitch as f32,
        yaw: yaw as f32,
        xacc: specific_force.x as f32,
        yacc: specific_force.y as f32,
        zacc: specific_force.z as f32,
        xgyro: p as f32,
        ygyro: q as f32,
        zgyro: r as f32,
        lat: deg_e7(truth.lat_deg),
        lng: deg_e7(truth.lon_deg),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simstate_carries_the_simulators_truth() {
        let half = std::f64::consts::FRAC_PI_4;
        let s = simstate(&GroundTruth {
            // Facing east, climbing at 1 m/s² (up is −down), turning right at 0.1 rad/s.
            attitude: [half.cos(), 0.0, 0.0, half.sin()],
            acceleration_ned_m_s2: [0.0, 0.0, -1.0],
            angular_velocity_rad_s: [0.0, 0.0, 0.1],
            lat_deg: 6.7971,
            lon_deg: 79.9017,
            ..GroundTruth::default()
        })
        .expect("a valid attitude");
        assert!((f64::from(s.yaw) - std::f64::consts::FRAC_PI_2).abs() < 1e-6, "{s:?}");
        assert!(s.roll.abs() < 1e-6 && s.pitch.abs() < 1e-6, "{s:?}");
        // An accelerometer at rest reads −g on its down axis; climbing adds to it.
        assert!((f64::from(s.zacc) + GRAVITY_M_S2 + 1.0).abs() < 1e-5, "{s:?}");
        assert!(s.xacc.abs() < 1e-5 && s.yacc.abs() < 1e-5, "{s:?}");
        assert_eq!((s.zgyro, s.lat, s.lng), (0.1, 67_971_000, 799_017_000));
        let zero = GroundTruth { attitude: [0.0; 4], ..GroundTruth::default() };
        assert!(simstate(&zero).is_none(), "no rotation, no SIMSTATE");
    }
}
