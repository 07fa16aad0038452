//! Telemetry: which messages go out how often ([`streams`]: defaults,
//! MAV_CMD_SET_MESSAGE_INTERVAL, legacy REQUEST_DATA_STREAM) and how each one is filled from the
//! graph's latest state ([`encode`], one file per message); MAV_CMD_REQUEST_MESSAGE builds one at
//! once. This file holds the state they share, the [`Snapshot`].
#![allow(
    deprecated,
    reason = "legacy REQUEST_DATA_STREAM is still spoken by ground stations and must be accepted"
)]

pub mod encode;
pub mod streams;

use std::time::Duration;

use kestrel_proto::Time;
use kestrel_proto::geo::Geodetic;
use kestrel_proto::messages::{
    ActuatorOutputs, AvoidanceCommand, BaroSample, BatteryStatus, DepthGrid, EscPulses, EstimatorStatus,
    GpsFix, GroundTruth, ImuSample, ManualControl, NavState, RangefinderSample, Setpoint, VehicleStatus,
};
use mavlink::MessageData;
use mavlink::dialects::ardupilotmega::{
    DISTANCE_SENSOR_DATA, MISSION_CURRENT_DATA, MavDataStream, MavMessage, MavResult,
};

pub use encode::debug_vect::AVOIDANCE_VECT_NAME;
pub use encode::distance_sensor::{OUT_OF_RANGE_ADD_CM, RANGEFINDER_STALE, distance_sensor_id};
use streams::Streams;

/// The graph's latest state, as telemetry needs it.
#[derive(Debug, Default)]
pub struct Snapshot {
    pub nav: Option<NavState>,
    pub gps: Option<GpsFix>,
    pub battery: Option<BatteryStatus>,
    pub status: Option<VehicleStatus>,
    pub depth: Option<DepthGrid>,
    pub avoidance: Option<AvoidanceCommand>,
    /// The estimator's innovations and health (for EKF_STATUS_REPORT's test ratios).
    pub estimator: Option<EstimatorStatus>,
    /// Whether a flight mission is stored (for MISSION_CURRENT).
    pub mission_items: u16,
    /// The simulator's ground truth (for SIMSTATE); never on hardware.
    pub truth: Option<GroundTruth>,
    /// Each rangefinder's newest usable sample (for DISTANCE_SENSOR), indexed by its
    /// [`distance_sensor_id`]: down, then up.
    pub rangefinders: [Option<RangefinderSample>; 2],
    /// The IMU's newest sample (for RAW_IMU, SCALED_IMU, HIGHRES_IMU).
    pub imu: Option<ImuSample>,
    /// The barometer's newest sample (for SCALED_PRESSURE).
    pub baro: Option<BaroSample>,
    /// The mixer's newest motor outputs (for SERVO_OUTPUT_RAW).
    pub actuators: Option<ActuatorOutputs>,
    /// The newest direct pulses (a motor test's, for SERVO_OUTPUT_RAW while obeyed).
    pub esc_pulses: Option<EscPulses>,
    /// The commander's newest setpoint (for POSITION_TARGET_LOCAL_NED / GLOBAL_INT and
    /// NAV_CONTROLLER_OUTPUT).
    pub setpoint: Option<Setpoint>,
    /// The newest sticks on the graph, the receiver's or a ground station's (for RC_CHANNELS).
    pub sticks: Option<ManualControl>,
}

/// The telemetry scheduler and message builder.
#[derive(Debug, Default)]
pub struct Telemetry {
    streams: Streams,
    pub snapshot: Snapshot,
    /// Whether a refused sample of each rangefinder (by [`distance_sensor_id`]) was logged: a
    /// broken sensor at 100 Hz must not flood the log.
    rangefinder_refusal_logged: [bool; 2],
}

impl Telemetry {
    /// Default streams, no state yet.
    pub fn new() -> Telemetry {
        Telemetry::default()
    }

    /// The interval of message `id` (`None`: not streamed).
    pub fn interval(&self, id: u32) -> Option<Duration> {
        self.streams.interval(id)
    }

    /// MAV_CMD_SET_MESSAGE_INTERVAL: `interval_us` -1 stops, 0 restores the default, > 0 sets.
    pub fn set_interval(&mut self, id: f64, interval_us: f64, now: Time) -> MavResult {
        self.streams.set_interval(id, interval_us, now)
    }

    /// REQUEST_DATA_STREAM, mapped onto our messages as ArduPilot groups them.
    pub fn request_data_stream(&mut self, stream: MavDataStream, rate_hz: u16, start: bool, now: Time) {
        self.streams.request_data_stream(stream, rate_hz, start, now);
    }

    /// Every stream message due at `now`.
    pub fn due(&mut self, now: Time) -> Vec<MavMessage> {
        let mut due = Vec::new();
        let Telemetry { streams, snapshot, .. } = self;
        streams.take_due(now, |id| {
            if id == DISTANCE_SENSOR_DATA::ID {
                due.extend(encode::distance_sensor::fresh(snapshot, now));
            } else {
                due.extend(encode::build(snapshot, id, now));
            }
        });
        due
    }

    /// A rangefinder's newest sample, kept for DISTANCE_SENSOR; one that cannot be used is
    /// dropped, and logged the first time for each sensor.
    pub fn on_rangefinder(&mut self, sample: RangefinderSample) {
        let id = usize::from(distance_sensor_id(sample.orientation));
        match sample.invalid() {
            None => self.snapshot.rangefinders[id] = Some(sample),
            Some(why) => {
                if !std::mem::replace(&mut self.rangefinder_refusal_logged[id], true) {
                    tracing::warn!(
                        orientation = ?sample.orientation,
                        "rangefinder sample refused, not sent to the ground station: {why} (further refusals are not logged)"
                    );
                }
            }
        }
    }

    /// Message `id` from the latest state (`None`: not ours, or nothing known yet).
    pub fn build(&self, id: u32, now: Time) -> Option<MavMessage> {
        encode::build(&self.snapshot, id, now)
    }

    /// MISSION_CURRENT now, when the commander already shows item `index` current: the spec
    /// wants one after every set-current request, changed or not (a change sends its own when
    /// the status shows it).
    pub fn mission_current_if_shown(&self, index: u32) -> Option<MavMessage> {
        let shown = self.snapshot.status.as_ref().is_some_and(|s| s.mission.current == index);
        shown.then(|| self.build(MISSION_CURRENT_DATA::ID, Time::ZERO)).flatten()
    }
}

/// Where home is, if the estimator has anchored its frame.
pub fn home(snapshot: &Snapshot) -> Option<Geodetic> {
    snapshot.nav.as_ref().and_then(|n| n.origin)
}

#[cfg(test)]
mod tests {
    use kestrel_proto::messages::RangefinderOrientation;
    use mavlink::dialects::ardupilotmega::{
        ATTITUDE_DATA, DISTANCE_SENSOR_DATA, GLOBAL_POSITION_INT_DATA, GPS_RAW_INT_DATA,
        MavSensorOrientation, SIMSTATE_DATA, WIND_DATA,
    };

    use super::*;

    fn nav() -> NavState {
        encode::nav_facing_east()
    }

    #[test]
    fn the_avoiders_correction_goes_out_as_debug_vect_at_5_hz() {
        let mut t = Telemetry::new();
        let count = |t: &mut Telemetry, from_ms: u64| {
            (from_ms..from_ms + 1000)
                .step_by(20)
                .flat_map(|ms| t.due(Time::from_micros(ms * 1000)))
                .filter_map(|m| match m {
                    MavMessage::DEBUG_VECT(d) => Some(d),
                    _ => None,
                })
                .collect::<Vec<_>>()
        };
        assert!(count(&mut t, 0).is_empty(), "nothing before the avoider speaks");
        t.snapshot.avoidance = Some(AvoidanceCommand {
            time: Time::from_micros(123),
            velocity_frd_m_s: [-1.5, 0.5, -0.25],
            ..AvoidanceCommand::default()
        });
        let sent = count(&mut t, 1000);
        assert_eq!(sent.len(), 5);
        let d = &sent[0];
        assert_eq!((d.x, d.y, d.z, d.time_usec), (-1.5, 0.5, -0.25, 123));
        assert_eq!(&d.name.to_str().expect("ascii").trim_end_matches('\0'), &AVOIDANCE_VECT_NAME);
    }

    #[test]
    fn rangefinder_samples_become_distance_sensor_in_centimetres_at_10_hz() {
        let sample = |orientation, time_us, distance_m| RangefinderSample {
            time: Time::from_micros(time_us),
            orientation,
            distance_m,
            min_range_m: 0.1,
            max_range_m: 12.0,
        };
        let mut t = Telemetry::new();
        t.on_rangefinder(sample(RangefinderOrientation::Down, 995_000, Some(3.456)));
        // Open sky above: nothing within the 12 m.
        t.on_rangefinder(sample(RangefinderOrientation::Up, 998_000, None));
        let Some(MavMessage::DISTANCE_SENSOR(down)) =
            t.build(DISTANCE_SENSOR_DATA::ID, Time::from_micros(1_000_000))
        else {
            panic!("the downward one first")
        };
        // Its fields are the encoder's (encode/distance_sensor.rs tests them all).
        assert_eq!(
            (down.orientation, down.current_distance),
            (MavSensorOrientation::MAV_SENSOR_ROTATION_PITCH_270, 346)
        );
        let sent = |t: &mut Telemetry, from_ms: u64, to_ms: u64| {
            (from_ms..to_ms)
                .step_by(20)
                .flat_map(|ms| t.due(Time::from_micros(ms * 1000)))
                .filter_map(|m| match m {
                    MavMessage::DISTANCE_SENSOR(d) => Some(d),
                    _ => None,
                })
                .collect::<Vec<_>>()
        };
        // 10 Hz for each, while the samples are younger than 200 ms.
        let fresh = sent(&mut t, 1000, 1200);
        assert_eq!(fresh.len(), 4, "{fresh:?}");
        let up = fresh.iter().find(|d| d.id == 1).expect("the upward one");
        // Out of range high reads 100 cm beyond the maximum, as ArduPilot's TFmini drivers.
        assert_eq!((up.current_distance, up.max_distance, up.time_boot_ms), (1300, 1200, 998));
        assert_eq!(up.orientation, MavSensorOrientation::MAV_SENSOR_ROTATION_PITCH_90);
        for o in [RangefinderOrientation::Up, RangefinderOrientation::Down] {
            let mavlink = fresh.iter().find(|d| d.id == distance_sensor_id(o)).expect("both");
            assert_eq!(mavlink.orientation as u8, o.mavlink_rotation(), "{o:?}");
        }
        assert!(sent(&mut t, 1200, 2000).is_empty(), "a sensor quiet for 200 ms is not reported");

        // A sample its own ranges refuse is dropped; the last good one stays.
        t.on_rangefinder(sample(RangefinderOrientation::Down, 2_000_000, Some(3.0)));
        t.on_rangefinder(sample(RangefinderOrientation::Down, 2_010_000, Some(f64::NAN)));
        t.on_rangefinder(sample(RangefinderOrientation::Down, 2_020_000, Some(12.5)));
        let after = sent(&mut t, 2000, 2100);
        assert!(
            after.iter().all(|d| d.id == 0 && d.current_distance == 300 && d.time_boot_ms == 2000),
            "{after:?}"
        );
        assert!(!after.is_empty());
        t.request_data_stream(MavDataStream::MAV_DATA_STREAM_EXTRA3, 2, true, Time::ZERO);
        assert_eq!(
            t.interval(DISTANCE_SENSOR_DATA::ID),
            Some(Duration::from_millis(500)),
            "in EXTRA3, as ArduPilot"
        );
    }

    #[test]
    fn default_rates_and_interval_changes() {
        let mut t = Telemetry::new();
        t.snapshot.nav = Some(nav());
        let count = |t: &mut Telemetry| {
            let mut n = 0;
            for ms in (0..1000).step_by(20) {
                n += t
                    .due(Time::from_micros(ms * 1000))
                    .iter()
                    .filter(|m| matches!(m, MavMessage::ATTITUDE(_)))
                    .count();
            }
            n
        };
        assert_eq!(count(&mut t), 10);
        let mut t = Telemetry::new();
        t.snapshot.nav = Some(nav());
        assert_eq!(
            t.set_interval(f64::from(ATTITUDE_DATA::ID), 50_000.0, Time::ZERO),
            MavResult::MAV_RESULT_ACCEPTED
        );
        assert_eq!(count(&mut t), 20);
        assert_eq!(
            t.set_interval(f64::from(ATTITUDE_DATA::ID), -1.0, Time::ZERO),
            MavResult::MAV_RESULT_ACCEPTED
        );
        assert_eq!(t.interval(ATTITUDE_DATA::ID), None);
        assert_eq!(
            t.set_interval(f64::from(ATTITUDE_DATA::ID), 0.0, Time::ZERO),
            MavResult::MAV_RESULT_ACCEPTED
        );
        assert_eq!(t.interval(ATTITUDE_DATA::ID), Some(Duration::from_millis(100)));
        assert_eq!(t.set_interval(9999.0, 1.0, Time::ZERO), MavResult::MAV_RESULT_UNSUPPORTED);
        t.request_data_stream(MavDataStream::MAV_DATA_STREAM_EXTRA1, 2, true, Time::ZERO);
        assert_eq!(t.interval(ATTITUDE_DATA::ID), Some(Duration::from_millis(500)));
    }

    #[test]
    fn messages_carry_the_state_in_mavlink_units() {
        let mut t = Telemetry::new();
        t.snapshot.nav = Some(nav());
        let Some(MavMessage::GLOBAL_POSITION_INT(g)) = t.build(GLOBAL_POSITION_INT_DATA::ID, Time::ZERO)
        else {
            panic!()
        };
        assert_eq!(g.relative_alt, 30_000);
        assert_eq!(g.alt, 50_000);
        assert_eq!(g.hdg, 9_000, "facing east");
        assert!((f64::from(g.lat) * 1e-7 - 6.79710 - 10.0 / 110_600.0).abs() < 1e-5, "{}", g.lat);
        let Some(MavMessage::ATTITUDE(a)) = t.build(ATTITUDE_DATA::ID, Time::ZERO) else { panic!() };
        assert!((f64::from(a.yaw) - std::f64::consts::FRAC_PI_2).abs() < 1e-6);
        assert!(t.build(GPS_RAW_INT_DATA::ID, Time::ZERO).is_none(), "no fix yet, nothing to send");
    }

    #[test]
    fn wind_and_simstate_go_out_only_once_there_is_something_to_say() {
        let mut t = Telemetry::new();
        t.snapshot.estimator = Some(EstimatorStatus::default());
        assert!(t.build(WIND_DATA::ID, Time::ZERO).is_none(), "no wind learnt, no WIND");
        t.snapshot.estimator =
            Some(EstimatorStatus { wind_ne_m_s: Some([0.0, 1.0]), ..EstimatorStatus::default() });
        assert!(matches!(t.build(WIND_DATA::ID, Time::ZERO), Some(MavMessage::WIND(_))));
        assert_eq!(t.interval(WIND_DATA::ID), Some(Duration::from_secs(1)));

        assert!(t.build(SIMSTATE_DATA::ID, Time::ZERO).is_none(), "no truth on hardware, no SIMSTATE");
        t.snapshot.truth = Some(GroundTruth::default());
        assert!(matches!(t.build(SIMSTATE_DATA::ID, Time::ZERO), Some(MavMessage::SIMSTATE(_))));
        assert_eq!(t.interval(SIMSTATE_DATA::ID), Some(Duration::from_millis(100)));
        t.request_data_stream(MavDataStream::MAV_DATA_STREAM_EXTRA1, 4, true, Time::ZERO);
        assert_eq!(
            t.interval(SIMSTATE_DATA::ID),
            Some(Duration::from_millis(250)),
            "in EXTRA1, as ArduPilot"
        );
    }
}
