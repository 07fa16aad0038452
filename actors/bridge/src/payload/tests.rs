use kestrel_proto::Time;
use kestrel_proto::messages::{
    AvoidanceCommand, Command, CommandResult, DepthGrid, Failsafe, FailsafeAction, FailsafeCause, FlightMode,
    GridRegion, GroundTruth, LandedState, NavState, OBSTACLE_SECTORS, ObstacleSectors, Setpoint,
    SetpointTarget, TrajectorySetpoint, VehicleCommand,
};
use proptest::prelude::*;

use super::*;
use crate::catalogue::{FIRST_BRIDGED_COMMAND_ID, TOPICS};

/// The sender's clock started at this UNIX time (µs); the receiver's `LATER_US` after it.
const SENDER_ORIGIN_US: i64 = 1_780_000_000_000_000;
const LATER_US: i64 = 2_500_000;

fn t(s: f64) -> Time {
    Time::from_secs_f64(s)
}

fn sent_and_received<T: Bridged>(msg: &T, later_us: i64) -> T {
    let sender = ClockOrigin::at(Time::ZERO, SENDER_ORIGIN_US);
    let receiver = ClockOrigin::at(Time::ZERO, SENDER_ORIGIN_US + later_us);
    let out = encode(msg).unwrap();
    assert_eq!((out.topic, out.schema, out.captured), (T::TOPIC, T::TYPE_NAME, msg.time()));
    let encoding = encoding_name(out.schema);
    let sample = Received {
        key: "kestrel/v/t",
        encoding: &encoding,
        payload: &out.json,
        captured_unix_us: Some(sender.to_unix_us(out.captured)),
    };
    decode::<T>(sample, receiver, RECEIVER_NOW).unwrap().msg
}

/// The receiver's clock when a test's message arrives: long after any capture time of these
/// tests, so none is clamped.
const RECEIVER_NOW: Time = Time::from_micros(1 << 50);

/// Sends `msg` to a receiver whose clock started 2.5 s later: every time comes back 2.5 s
/// earlier, everything else bit for bit. Returns the topic, for the coverage check.
fn round_trip<T: Bridged + PartialEq>(msg: T) -> &'static str {
    let back = sent_and_received(&msg, LATER_US);
    let mut expected = msg.clone();
    expected.shift_times(-LATER_US);
    assert_eq!(back, expected, "{}", T::TYPE_NAME);
    assert_eq!(back.time(), msg.time().saturating_sub(std::time::Duration::from_micros(2_500_000)));
    let mut undone = back;
    undone.shift_times(LATER_US);
    assert_eq!(serde_json::to_string(&undone).unwrap(), serde_json::to_string(&msg).unwrap());
    T::TOPIC
}

fn nav_state() -> NavState {
    let mut nav = NavState::exact(
        t(12.0),
        [0.9, 0.1, -0.2, 0.3],
        [0.01, -0.02, 0.3],
        [1.5, -2.25, 0.125],
        [10.0, -3.3, -7.1],
    );
    nav.covariance_diagonal[7] = 1e-7;
    nav
}

fn depth_grid() -> DepthGrid {
    let region = GridRegion { near_share: 0.25, invalid_share: 0.1, nearest_m: Some(3.75) };
    let mut regions = [[GridRegion::default(); 3]; 3];
    regions[1][1] = region;
    DepthGrid {
        time: t(20.0),
        frame_sequence: 301,
        threshold_m: 5.0,
        regions,
        sectors: ObstacleSectors {
            distances_cm: vec![u16::MAX; OBSTACLE_SECTORS],
            increment_deg: 1.5,
            angle_offset_deg: -53.25,
            min_distance_cm: 20,
            max_distance_cm: 2000,
        },
    }
}

#[test]
fn every_bridged_message_round_trips_with_its_times_moved_onto_the_receivers_clock() {
    let mut status =
        kestrel_proto::testing::vehicle_status(t(30.0), true, FlightMode::Auto, LandedState::InAir);
    status.failsafe =
        Some(Failsafe { cause: FailsafeCause::AvoidanceLost, action: FailsafeAction::Hold, since: t(29.5) });
    status.last_refusal = Some("arming refused: not landed".into());
    let covered = [
        round_trip(nav_state()),
        round_trip(GroundTruth {
            time: t(11.0),
            lat_deg: 6.7971,
            clearance_m: Some(2.5),
            ..GroundTruth::default()
        }),
        round_trip(Setpoint {
            time: t(13.0),
            armed: true,
            target: SetpointTarget::Trajectory(TrajectorySetpoint {
                position_ned_m: [Some(1.0), None, Some(-5.0)],
                velocity_ned_m_s: [None, Some(0.3), None],
                desired_speed_m_s: Some(3.0),
                ..TrajectorySetpoint::default()
            }),
            landing: false,
            failed_motor: None,
        }),
        round_trip(depth_grid()),
        round_trip(AvoidanceCommand {
            time: t(21.0),
            grid_time: Some(t(20.0)),
            frame_sequence: Some(301),
            velocity_frd_m_s: [-0.5, 1.25, 0.0],
            ..AvoidanceCommand::default()
        }),
        round_trip(status),
        round_trip(VehicleCommand {
            id: FIRST_BRIDGED_COMMAND_ID,
            time: t(40.0),
            command: Command::Takeoff { altitude_m: 5.0 },
        }),
        round_trip(CommandResult { time: t(40.1), id: 7, command: Command::Arm, refusal: Some("no".into()) }),
    ];
    let mut covered = covered.to_vec();
    covered.sort_unstable();
    let mut all = TOPICS.to_vec();
    all.sort_unstable();
    assert_eq!(covered, all, "a round trip per bridged topic");
}

#[test]
fn a_sample_without_a_timestamp_is_taken_as_captured_on_arrival() {
    let out = encode(&nav_state()).unwrap();
    let local = ClockOrigin::at(Time::ZERO, SENDER_ORIGIN_US);
    let encoding = encoding_name(out.schema);
    let sample = Received { key: "k", encoding: &encoding, payload: &out.json, captured_unix_us: None };
    let nav: NavState = decode(sample, local, t(3.0)).unwrap().msg;
    assert_eq!(nav.time, t(3.0));
    // Schema-less JSON (a client that names only the media type) is read too.
    let sample = Received { encoding: MEDIA_TYPE, ..sample };
    assert_eq!(decode::<NavState>(sample, local, t(4.0)).unwrap().msg.time, t(4.0));
}

#[test]
fn a_wrong_encoding_schema_or_payload_and_a_command_in_the_links_id_range_are_refused() {
    let local = ClockOrigin::at(Time::ZERO, 0);
    let out = encode(&nav_state()).unwrap();
    let refused = |encoding: &str, payload: &[u8]| {
        let sample = Received { key: "kestrel/v/nav_state", encoding, payload, captured_unix_us: None };
        decode::<NavState>(sample, local, t(1.0)).unwrap_err().to_string()
    };
    let e = refused("text/plain", &out.json);
    assert!(e.contains("kestrel/v/nav_state") && e.contains("is not application/json"), "{e}");
    let e = refused("application/json;kestrel.GroundTruth", &out.json);
    assert!(e.contains("schema 'kestrel.GroundTruth' is not this topic's"), "{e}");
    let e = refused("application/json", &out.json[..out.json.len() / 2]);
    assert!(e.contains("kestrel.NavState") && e.contains("EOF"), "{e}");
    // JSON has no NaN: serde_json writes a non-finite float as null, which no f64 reads back.
    let text = String::from_utf8(out.json.clone()).unwrap().replacen("1.5,", "null,", 1);
    let e = refused("application/json", text.as_bytes());
    assert!(e.contains("null"), "{e}");

    let cmd = VehicleCommand { id: 12, time: t(1.0), command: Command::Arm };
    let json = serde_json::to_vec(&cmd).unwrap();
    let sample = Received { key: "k", encoding: MEDIA_TYPE, payload: &json, captured_unix_us: None };
    let e = decode::<VehicleCommand>(sample, local, t(1.0)).unwrap_err().to_string();
    assert!(e.contains("command id 12 is in the link's range"), "{e}");
}

#[test]
fn the_send_time_attachment_reads_back_and_nothing_else_does() {
    assert_eq!(read_sent_attachment(&sent_attachment(-5)), Some(-5));
    assert_eq!(read_sent_attachment(&sent_attachment(SENDER_ORIGIN_US)), Some(SENDER_ORIGIN_US));
    assert_eq!(read_sent_attachment(b"1234567"), None);
    assert_eq!(read_sent_attachment(b""), None);
}

proptest! {
    /// However far apart the two clocks started, a message comes back captured at the same
    /// wall-clock instant (clamped at the receiver's start).
    #[test]
    fn capture_instants_survive_any_clock_offset(
        time_us in 0u64..100_000_000_000,
        later_us in -10_000_000_000i64..10_000_000_000,
    ) {
        let mut nav = nav_state();
        nav.time = Time::from_micros(time_us);
        let back = sent_and_received(&nav, later_us);
        let expected = i64::try_from(time_us).unwrap().saturating_sub(later_us).max(0);
        prop_assert_eq!(back.time.as_micros(), u64::try_from(expected).unwrap());
    }
}

/// A sample stamped `ahead_us` after its arrival on the receiver's wall clock.
fn received_ahead<T: Bridged>(msg: &T, ahead_us: i64, local: ClockOrigin, now: Time) -> Decoded<T> {
    let out = encode(msg).unwrap();
    let encoding = encoding_name(out.schema);
    let sample = Received {
        key: "kestrel/v/t",
        encoding: &encoding,
        payload: &out.json,
        captured_unix_us: Some(local.to_unix_us(now).saturating_add(ahead_us)),
    };
    decode::<T>(sample, local, now).unwrap()
}

#[test]
fn a_future_capture_time_is_clamped_to_the_arrival_and_by_how_much_is_returned() {
    let local = ClockOrigin::at(Time::ZERO, SENDER_ORIGIN_US);
    let now = t(100.0);
    let cmd = VehicleCommand { id: FIRST_BRIDGED_COMMAND_ID, time: t(1.0), command: Command::Arm };
    let later = received_ahead(&cmd, 3_600_000_000, local, now);
    assert_eq!((later.msg.time, later.clamped_by_us), (now, 3_600_000_000));
    let past = received_ahead(&cmd, -250_000, local, now);
    assert_eq!((past.msg.time, past.clamped_by_us), (t(99.75), 0));
    // A time inside the message later than its own capture time is clamped too: a grid time
    // 10 s after the command's, sent on time.
    let avoid = AvoidanceCommand { time: t(1.0), grid_time: Some(t(11.0)), ..AvoidanceCommand::default() };
    let got = received_ahead(&avoid, 0, local, now);
    assert_eq!((got.msg.time, got.msg.grid_time, got.clamped_by_us), (now, Some(now), 10_000_000));
}

proptest! {
    /// Whatever the sender's clock, the capture time it claims and the times inside the
    /// message, no time the receiver takes is after its own clock, and the amount reported is
    /// exactly how far the furthest one was.
    #[test]
    fn a_clamped_time_is_never_after_the_host_clock(
        time_us in 0u64..100_000_000_000,
        grid_after_us in 0u64..10_000_000_000,
        ahead_us in -10_000_000_000i64..10_000_000_000,
        now_us in 0u64..100_000_000_000,
    ) {
        let local = ClockOrigin::at(Time::ZERO, SENDER_ORIGIN_US);
        let now = Time::from_micros(now_us);
        let avoid = AvoidanceCommand {
            time: Time::from_micros(time_us),
            grid_time: Some(Time::from_micros(time_us + grid_after_us)),
            ..AvoidanceCommand::default()
        };
        let got = received_ahead(&avoid, ahead_us, local, now);
        prop_assert!(got.msg.time <= now);
        prop_assert!(got.msg.grid_time.unwrap() <= now);
        // Unclamped, the grid time would land at now + ahead + grid_after (floored at zero).
        let grid_unclamped = i128::from(now_us) + i128::from(ahead_us) + i128::from(grid_after_us);
        let expected = u64::try_from((grid_unclamped - i128::from(now_us)).max(0)).unwrap();
        prop_assert_eq!(got.clamped_by_us, expected);
    }
}
