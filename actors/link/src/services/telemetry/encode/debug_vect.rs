//! DEBUG_VECT named [`AVOIDANCE_VECT_NAME`]: the obstacle avoider's correction as ground
//! stations graph it (QGroundControl's MAVLink inspector, MAVProxy's `graph DEBUG_VECT.x`).

use kestrel_proto::messages::AvoidanceCommand;
use mavlink::dialects::ardupilotmega::DEBUG_VECT_DATA;

/// Name of the DEBUG_VECT carrying the obstacle avoider's correction.
pub const AVOIDANCE_VECT_NAME: &str = "AVOID";

/// The avoider's correction: x forward, y right, z down (m/s, body FRD), stamped with its depth
/// grid's capture time.
pub fn debug_vect(a: &AvoidanceCommand) -> DEBUG_VECT_DATA {
    let [x, y, z] = a.velocity_frd_m_s.map(|v| v as f32);
    let mut name = [0u8; 10];
    name[..AVOIDANCE_VECT_NAME.len()].copy_from_slice(AVOIDANCE_VECT_NAME.as_bytes());
    DEBUG_VECT_DATA { time_usec: a.time.as_micros(), x, y, z, name: name.into() }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;

    use super::*;

    #[test]
    fn the_correction_is_named_and_stamped_with_its_grids_time() {
        let d = debug_vect(&AvoidanceCommand {
            time: Time::from_micros(123),
            velocity_frd_m_s: [-1.5, 0.5, -0.25],
            ..AvoidanceCommand::default()
        });
        assert_eq!((d.x, d.y, d.z, d.time_usec), (-1.5, 0.5, -0.25, 123));
        assert_eq!(&d.name.to_str().expect("ascii").trim_end_matches('\0'), &AVOIDANCE_VECT_NAME);
    }
}
