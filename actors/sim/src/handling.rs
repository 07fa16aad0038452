//! The person who handles the vehicle during a calibration: while it is disarmed on
//! the ground and a calibration asks for a [`Motion`], the simulator stops its physics and
//! holds the airframe in the pose a careful person would — turned slowly through every
//! orientation for the compass, set down still in each of ArduPilot's six accelerometer
//! positions, level on its legs — so a calibration runs end to end without hardware.
//! [`Handling`] also makes the mistakes the calibration must refuse: holding the vehicle in one
//! orientation, or shaking it.

use kestrel_proto::messages::Motion;
use nalgebra::UnitQuaternion;
use serde::Deserialize;

/// How the simulated person handles the vehicle (`[actors.sim.params] handling`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Handling {
    /// As asked.
    #[default]
    Careful,
    /// Never turns it: a compass calibration sees one orientation only.
    OneOrientation,
    /// Shakes it while it should stand still (±5° at 1.5 Hz).
    Shaking,
}

/// Rates of the compass tumble about the three Euler axes (rad/s): incommensurate, so the
/// field sweeps the whole sphere of body directions within a few seconds.
const TUMBLE_RAD_S: [f64; 3] = [1.3, 0.61, 0.9];

/// Roll and pitch of ACCELCAL_VEHICLE_POS `position` (rad): 1 level, 2 left side down,
/// 3 right side down, 4 nose down, 5 nose up, 6 upside down; `None` for another number.
pub fn placement_rad(position: u32) -> Option<(f64, f64)> {
    use std::f64::consts::{FRAC_PI_2, PI};
    Some(match position {
        1 => (0.0, 0.0),
        2 => (-FRAC_PI_2, 0.0),
        3 => (FRAC_PI_2, 0.0),
        4 => (0.0, -FRAC_PI_2),
        5 => (0.0, FRAC_PI_2),
        6 => (PI, 0.0),
        _ => return None,
    })
}

/// The airframe's attitude (FRD → NED) `t_s` seconds into `motion`, starting from heading
/// `yaw_rad`; `None` for [`Motion::Idle`] and [`Motion::PropsOff`] (the physics runs).
pub fn pose(motion: Motion, handling: Handling, t_s: f64, yaw_rad: f64) -> Option<UnitQuaternion<f64>> {
    let shake = if handling == Handling::Shaking {
        5f64.to_radians() * (std::f64::consts::TAU * 1.5 * t_s).sin()
    } else {
        0.0
    };
    let (roll, pitch, yaw) = match motion {
        Motion::Idle | Motion::PropsOff => return None,
        Motion::Tumble if handling == Handling::OneOrientation => (0.0, 0.0, yaw_rad),
        Motion::Tumble => {
            let [r, p, y] = TUMBLE_RAD_S.map(|w| w * t_s);
            (r, p, yaw_rad + y)
        }
        Motion::Level => (shake, 0.0, yaw_rad),
        Motion::Place { position } => {
            let (roll, pitch) = placement_rad(position).unwrap_or((0.0, 0.0));
            (roll + shake, pitch, yaw_rad)
        }
    };
    Some(UnitQuaternion::from_euler_angles(roll, pitch, yaw))
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;

    #[test]
    fn each_placement_points_the_axis_ardupilot_names_up() {
        // The specific force at rest is "up" in the body: what the accelerometer reads.
        let g = 9.80665;
        let expected = [
            [0.0, 0.0, -g], // level
            [0.0, g, 0.0],  // left side down: the right side points up
            [0.0, -g, 0.0],
            [-g, 0.0, 0.0], // nose down: the tail points up
            [g, 0.0, 0.0],
            [0.0, 0.0, g],
        ];
        for (position, want) in (1..=6).zip(expected) {
            let q = pose(Motion::Place { position }, Handling::Careful, 3.0, 0.7).expect("a pose");
            let up_body = q.inverse_transform_vector(&Vector3::new(0.0, 0.0, -g));
            assert!((up_body - Vector3::from(want)).norm() < 1e-9, "{position}: {up_body}");
        }
        assert!(pose(Motion::Idle, Handling::Careful, 1.0, 0.0).is_none());
        assert!(placement_rad(7).is_none());
    }

    #[test]
    fn the_tumble_sweeps_the_sphere_unless_the_person_holds_still() {
        let field = Vector3::new(0.41, 0.0, -0.025);
        let directions = |handling| -> Vec<Vector3<f64>> {
            (0..4000)
                .map(|i| {
                    let q = pose(Motion::Tumble, handling, f64::from(i) * 0.01, 0.0).expect("a pose");
                    q.inverse_transform_vector(&field).normalize()
                })
                .collect()
        };
        let careful = directions(Handling::Careful);
        // Every octant of body directions is visited within the 40 s a compass calibration collects.
        for octant in 0..8 {
            let sign = |bit: i32| if octant & (1 << bit) == 0 { 1.0 } else { -1.0 };
            assert!(
                careful.iter().any(|d| d.x * sign(0) > 0.1 && d.y * sign(1) > 0.1 && d.z * sign(2) > 0.1),
                "octant {octant} never seen"
            );
        }
        let frozen = directions(Handling::OneOrientation);
        assert!(frozen.iter().all(|d| (d - frozen[0]).norm() < 1e-12));
    }
}
