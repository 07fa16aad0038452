//! OBSTACLE_DISTANCE: the stereo depth grid's nearest obstacle per horizontal sector (cm, body
//! FRD, clockwise from forward), as ArduPilot's proximity library and QGroundControl read it.

use kestrel_proto::Time;
use kestrel_proto::messages::{OBSTACLE_SECTORS, ObstacleSectors};
use mavlink::dialects::ardupilotmega::{MavDistanceSensor, MavFrame, OBSTACLE_DISTANCE_DATA};

/// OBSTACLE_DISTANCE for `sectors` of the depth grid captured at `time`; sectors the grid does
/// not fill are unknown (UINT16_MAX).
pub fn obstacle_distance(time: Time, sectors: &ObstacleSectors) -> OBSTACLE_DISTANCE_DATA {
    let mut distances = [u16::MAX; OBSTACLE_SECTORS];
    for (out, v) in distances.iter_mut().zip(&sectors.distances_cm) {
        *out = *v;
    }
    OBSTACLE_DISTANCE_DATA {
        time_usec: time.as_micros(),
        distances,
        min_distance: sectors.min_distance_cm,
        max_distance: sectors.max_distance_cm,
        sensor_type: MavDistanceSensor::MAV_DISTANCE_SENSOR_UNKNOWN,
        increment: 0,
        increment_f: sectors.increment_deg,
        angle_offset: sectors.angle_offset_deg,
        frame: MavFrame::MAV_FRAME_BODY_FRD,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sectors_keep_their_distances_and_angles_and_missing_ones_are_unknown() {
        let sectors = ObstacleSectors {
            distances_cm: vec![300, 1201, u16::MAX],
            increment_deg: 5.0,
            angle_offset_deg: -35.0,
            min_distance_cm: 20,
            max_distance_cm: 1200,
        };
        let o = obstacle_distance(Time::from_micros(42), &sectors);
        assert_eq!(&o.distances[..4], &[300, 1201, u16::MAX, u16::MAX]);
        assert_eq!((o.increment_f, o.angle_offset, o.min_distance, o.max_distance), (5.0, -35.0, 20, 1200));
        assert_eq!((o.time_usec, o.frame), (42, MavFrame::MAV_FRAME_BODY_FRD));
    }
}
