//! DISTANCE_SENSOR: each rangefinder's newest usable sample (cm), down then up, while fresh.

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::messages::{RangefinderOrientation, RangefinderSample};
use mavlink::dialects::ardupilotmega::{
    DISTANCE_SENSOR_DATA, MavDistanceSensor, MavMessage, MavSensorOrientation,
};

use super::super::Snapshot;

/// A rangefinder's sample older than this is not reported (a sensor gone quiet is no longer
/// in view): ArduPilot's backends mark a rangefinder `NoData` after 200 ms without a reading
/// (`AP_RangeFinder_Benewake_TFMiniPlus::update`), and `GCS_MAVLINK::send_distance_sensor` sends
/// nothing for a sensor without data.
pub const RANGEFINDER_STALE: Duration = Duration::from_millis(200);

/// What a reading beyond the sensor's range reports, above its maximum (cm): ArduPilot's
/// Benewake drivers (`AP_RangeFinder_Benewake::get_reading`,
/// `AP_RangeFinder_Benewake_TFMiniPlus::process_raw_measure`) turn a TFmini's "no return" into
/// `max(model maximum, RNGFND_MAX_CM + BENEWAKE_OUT_OF_RANGE_ADD_CM)`, 100 cm beyond the
/// maximum, and `GCS_MAVLINK::send_distance_sensor` sends that distance as `current_distance`;
/// a ground station (and ArduPilot's own MAVLink rangefinder backend) reads a distance above
/// `max_distance` as out of range high.
pub const OUT_OF_RANGE_ADD_CM: u16 = 100;

/// DISTANCE_SENSOR's `id` of the rangefinder looking `orientation`: 0 for the downward one, as
/// ArduPilot numbers its first rangefinder (the one its altitude comes from), 1 for the upward.
pub fn distance_sensor_id(orientation: RangefinderOrientation) -> u8 {
    match orientation {
        RangefinderOrientation::Down => 0,
        RangefinderOrientation::Up => 1,
    }
}

/// DISTANCE_SENSOR for `sample` (checked by [`RangefinderSample::invalid`]): distances in cm,
/// stamped with its measurement time (ArduPilot stamps the sending time, a TODO in its code),
/// a laser (a TFmini is a time-of-flight lidar) whose `covariance` is unknown (255: the sample
/// does not carry its noise).
pub fn distance_sensor(sample: &RangefinderSample) -> DISTANCE_SENSOR_DATA {
    let cm = |m: f64| (m * 100.0).round().clamp(0.0, f64::from(u16::MAX)) as u16;
    let max_distance = cm(sample.max_range_m);
    DISTANCE_SENSOR_DATA {
        time_boot_ms: (sample.time.as_micros() / 1000) as u32,
        min_distance: cm(sample.min_range_m),
        max_distance,
        current_distance: sample.distance_m.map_or(max_distance.saturating_add(OUT_OF_RANGE_ADD_CM), cm),
        mavtype: MavDistanceSensor::MAV_DISTANCE_SENSOR_LASER,
        id: distance_sensor_id(sample.orientation),
        orientation: match sample.orientation {
            RangefinderOrientation::Up => MavSensorOrientation::MAV_SENSOR_ROTATION_PITCH_90,
            RangefinderOrientation::Down => MavSensorOrientation::MAV_SENSOR_ROTATION_PITCH_270,
        },
        covariance: u8::MAX,
        ..Default::default()
    }
}

/// DISTANCE_SENSOR for every rangefinder whose newest sample is fresh at `now`, down first.
pub fn fresh(snap: &Snapshot, now: Time) -> impl Iterator<Item = MavMessage> + '_ {
    snap.rangefinders
        .iter()
        .flatten()
        .filter(move |s| now.saturating_since(s.time) <= RANGEFINDER_STALE)
        .map(|s| MavMessage::DISTANCE_SENSOR(distance_sensor(s)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(orientation: RangefinderOrientation, distance_m: Option<f64>) -> RangefinderSample {
        RangefinderSample {
            time: Time::from_micros(995_000),
            orientation,
            distance_m,
            min_range_m: 0.1,
            max_range_m: 12.0,
        }
    }

    #[test]
    fn a_reading_goes_out_in_centimetres_and_none_reads_100_cm_beyond_the_maximum() {
        assert_eq!(
            distance_sensor(&sample(RangefinderOrientation::Down, Some(3.456))),
            DISTANCE_SENSOR_DATA {
                time_boot_ms: 995,
                min_distance: 10,
                max_distance: 1200,
                current_distance: 346,
                mavtype: MavDistanceSensor::MAV_DISTANCE_SENSOR_LASER,
                id: 0,
                orientation: MavSensorOrientation::MAV_SENSOR_ROTATION_PITCH_270,
                covariance: 255,
                horizontal_fov: 0.0,
                vertical_fov: 0.0,
                quaternion: [0.0; 4],
                signal_quality: 0,
            }
        );
        let up = distance_sensor(&sample(RangefinderOrientation::Up, None));
        assert_eq!((up.current_distance, up.id), (1300, 1));
        assert_eq!(up.orientation, MavSensorOrientation::MAV_SENSOR_ROTATION_PITCH_90);
    }

    #[test]
    fn only_samples_younger_than_200_ms_are_fresh() {
        let mut snap = Snapshot::default();
        snap.rangefinders[0] = Some(sample(RangefinderOrientation::Down, Some(1.0)));
        assert_eq!(fresh(&snap, Time::from_micros(1_195_000)).count(), 1);
        assert_eq!(fresh(&snap, Time::from_micros(1_196_000)).count(), 0);
    }
}
