//! The companion behind a real hub: a flight controller on endpoint 0 and a ground station on
//! endpoint 1, frames in as bytes, frames out decoded.

use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega::{
    ATTITUDE_QUATERNION_DATA, COMMAND_LONG_DATA, HOME_POSITION_DATA, LOCAL_POSITION_NED_DATA, MavCmd,
    MavFrame, TIMESYNC_DATA,
};
use tokio::sync::mpsc;

use super::*;
use crate::frame::{FrameParser, encode};
use crate::hub::{Hub, Tx};
use crate::router::LinkId;

struct Bench {
    hub: Hub<Companion>,
    fc: LinkId,
    gcs: LinkId,
    fc_rx: mpsc::Receiver<Vec<u8>>,
    gcs_rx: mpsc::Receiver<Vec<u8>>,
    fc_seq: u8,
}

const FC: MavHeader = MavHeader { system_id: 1, component_id: 1, sequence: 0 };
const GCS: MavHeader = MavHeader { system_id: 255, component_id: 190, sequence: 0 };

fn t(ms: u64) -> Time {
    Time::from_micros(ms * 1000)
}

impl Bench {
    fn new() -> Bench {
        let mut hub = Hub::new(Companion::new(DEFAULT_COMPONENT_ID));
        let (tx, fc_rx) = mpsc::channel(10_000);
        let fc = hub.add_endpoint_link(FC_ENDPOINT, "fc".into(), Tx::Stream(tx), None);
        let (tx, gcs_rx) = mpsc::channel(10_000);
        let gcs = hub.add_endpoint_link(1, "gcs".into(), Tx::Stream(tx), None);
        Bench { hub, fc, gcs, fc_rx, gcs_rx, fc_seq: 0 }
    }

    fn feed(&mut self, link: LinkId, bytes: &[u8], now: Time) -> Vec<CompanionOut> {
        let mut frames = Vec::new();
        FrameParser::new().push(bytes, &mut frames);
        frames.iter().flat_map(|f| self.hub.on_frame(link, f, now)).collect()
    }

    fn fc_sends(&mut self, msg: MavMessage, now: Time) -> Vec<CompanionOut> {
        self.fc_seq = self.fc_seq.wrapping_add(1);
        let bytes = encode(MavHeader { sequence: self.fc_seq, ..FC }, &msg, None);
        self.feed(self.fc, &bytes, now)
    }

    fn heartbeat(&mut self, armed: bool, custom_mode: u32, now: Time) -> Vec<CompanionOut> {
        let base_mode = if armed { MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED } else { MavModeFlag::empty() }
            | MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
        self.fc_sends(
            MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                custom_mode,
                mavtype: MavType::MAV_TYPE_QUADROTOR,
                autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
                base_mode,
                system_status: MavState::MAV_STATE_STANDBY,
                mavlink_version: 3,
            }),
            now,
        )
    }

    /// Frames sent to a link since the last call, with their headers.
    fn sent(rx: &mut mpsc::Receiver<Vec<u8>>) -> Vec<(Frame, MavMessage)> {
        let mut out = Vec::new();
        while let Ok(bytes) = rx.try_recv() {
            let mut frames = Vec::new();
            FrameParser::new().push(&bytes, &mut frames);
            for f in frames {
                let m = f.decode().expect("decodes");
                out.push((f, m));
            }
        }
        out
    }

    /// Answers the companion's outstanding TIMESYNC request as a flight controller whose clock
    /// reads ours minus `behind_ms`, with no delay.
    fn answer_timesync(&mut self, now: Time, behind_ms: i64) {
        self.hub.on_tick(now);
        let request = Bench::sent(&mut self.fc_rx)
            .into_iter()
            .find_map(|(_, m)| match m {
                MavMessage::TIMESYNC(t) if t.tc1 == 0 => Some(t),
                _ => None,
            })
            .expect("a TIMESYNC request to the flight controller");
        assert_eq!((request.target_system, request.target_component), (1, 1));
        let tc1 = (now.as_micros() as i64 - behind_ms * 1000) * 1000;
        let answer =
            TIMESYNC_DATA { tc1, ts1: request.ts1, target_system: 1, target_component: DEFAULT_COMPONENT_ID };
        self.fc_sends(MavMessage::TIMESYNC(answer), now);
        assert!(self.hub.station().fc_clock().synced());
    }
}

fn attitude(boot_ms: u32) -> MavMessage {
    // 90° yaw (facing east).
    let h = std::f32::consts::FRAC_1_SQRT_2;
    MavMessage::ATTITUDE_QUATERNION(ATTITUDE_QUATERNION_DATA {
        time_boot_ms: boot_ms,
        q1: h,
        q2: 0.0,
        q3: 0.0,
        q4: h,
        rollspeed: 0.1,
        pitchspeed: 0.0,
        yawspeed: -0.2,
        ..Default::default()
    })
}

#[test]
fn silent_until_the_flight_controller_is_heard_then_an_onboard_controller_of_its_system() {
    let mut b = Bench::new();
    b.hub.send_heartbeat();
    b.hub.on_tick(t(1000));
    assert!(Bench::sent(&mut b.fc_rx).is_empty() && Bench::sent(&mut b.gcs_rx).is_empty());
    // A ground station's heartbeat on the flight controller's link is not a flight controller.
    let gcs_hb = HEARTBEAT_DATA {
        mavtype: MavType::MAV_TYPE_GCS,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        ..Default::default()
    };
    b.feed(b.fc, &encode(GCS, &MavMessage::HEARTBEAT(gcs_hb), None), t(1000));
    assert_eq!(b.hub.station().flight_controller(), None);
    b.heartbeat(false, 0, t(1010));
    assert_eq!(b.hub.station().flight_controller().map(|f| f.system_id), Some(1));
    Bench::sent(&mut b.gcs_rx);
    b.hub.send_heartbeat();
    for rx in [&mut b.fc_rx, &mut b.gcs_rx] {
        let sent = Bench::sent(rx);
        let (f, m) = &sent[0];
        assert_eq!((f.system_id, f.component_id), (1, 196));
        let MavMessage::HEARTBEAT(hb) = m else { panic!("{m:?}") };
        assert_eq!(
            (hb.mavtype, hb.autopilot),
            (MavType::MAV_TYPE_ONBOARD_CONTROLLER, MavAutopilot::MAV_AUTOPILOT_INVALID)
        );
    }
}

#[test]
fn the_flight_controller_state_is_published_on_our_clock_and_invalid_once_stale() {
    let mut b = Bench::new();
    b.heartbeat(true, 4, t(10_000));
    // Before the clocks are aligned no NavState is published.
    assert!(b.fc_sends(attitude(3_000), t(10_000)).is_empty());
    // The flight controller booted 7 s after us: its 3 s is our 10 s.
    b.answer_timesync(t(10_000), 7_000);
    b.fc_sends(
        MavMessage::HOME_POSITION(HOME_POSITION_DATA {
            latitude: 67_971_000,
            longitude: 799_017_000,
            altitude: 20_000,
            x: 1.0,
            y: -2.0,
            z: 0.5,
            ..Default::default()
        }),
        t(10_005),
    );
    b.fc_sends(
        MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
            time_boot_ms: 3_005,
            x: 4.0,
            y: 5.0,
            z: -6.0,
            vx: 1.0,
            vy: 0.0,
            vz: -0.5,
        }),
        t(10_010),
    );
    let out = b.fc_sends(attitude(3_020), t(10_021));
    let [CompanionOut::Nav(nav)] = out.as_slice() else { panic!("{out:?}") };
    assert_eq!(nav.time, t(10_020), "the attitude's boot time on our clock");
    assert_eq!(nav.position_ned_m, [4.0, 5.0, -6.0]);
    assert_eq!(nav.velocity_ned_m_s, [1.0, 0.0, -0.5]);
    assert!((nav.attitude[3] - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-6);
    assert_eq!(
        nav.valid,
        kestrel_proto::messages::NavValidity {
            horizontal_velocity_from_drag: false,
            ..kestrel_proto::messages::NavValidity::ALL
        }
    );
    let origin = nav.origin.expect("origin from home");
    assert!((origin.lat_deg - (6.7971 - 1.0 / 111_000.0)).abs() < 1e-6, "{origin:?}");
    // The heartbeat gives the status: GUIDED, armed, home in the local frame.
    let out = b.heartbeat(true, 4, t(10_030));
    let [CompanionOut::Status(status)] = out.as_slice() else { panic!("{out:?}") };
    assert_eq!((status.armed, status.mode), (true, FlightMode::Guided));
    assert_eq!(status.home.map(|h| h.position_ned_m), Some([1.0, -2.0, 0.5]));
    // Position goes quiet first: the next state says so.
    let out = b.fc_sends(attitude(3_600), t(10_600));
    let [CompanionOut::Nav(nav)] = out.as_slice() else { panic!("{out:?}") };
    assert!(nav.valid.attitude && !nav.valid.horizontal_position && !nav.valid.vertical_velocity);
    // Then the attitude: within STALE nothing, past it an invalid state, repeated at 10 Hz.
    assert!(b.hub.on_tick(t(11_050)).is_empty());
    let out = b.hub.on_tick(t(11_120));
    let [CompanionOut::Nav(nav)] = out.as_slice() else { panic!("{out:?}") };
    assert_eq!(nav.valid, kestrel_proto::messages::NavValidity::default(), "nothing valid");
    assert!(b.hub.on_tick(t(11_160)).is_empty());
    assert_eq!(b.hub.on_tick(t(11_220)).len(), 1);
}

use kestrel_proto::messages::FlightMode;

#[test]
fn a_rebooted_flight_controller_is_relearnt_before_anything_is_published() {
    let mut b = Bench::new();
    b.heartbeat(false, 0, t(10_000));
    b.answer_timesync(t(10_000), 7_000);
    assert_eq!(b.fc_sends(attitude(3_000), t(10_000)).len(), 1);
    // Boot time back to 0.5 s: the old offset would put this state 2.5 s in the past.
    assert!(b.fc_sends(attitude(500), t(10_100)).is_empty());
    b.answer_timesync(t(10_200), 10_200 - 600);
    let out = b.fc_sends(attitude(610), t(10_210));
    let [CompanionOut::Nav(nav)] = out.as_slice() else { panic!("{out:?}") };
    assert_eq!(nav.time, t(10_210));
}

#[test]
fn obstacle_distance_goes_to_the_flight_controller_in_its_clock() {
    let mut b = Bench::new();
    b.heartbeat(false, 0, t(10_000));
    b.answer_timesync(t(10_000), 7_000);
    Bench::sent(&mut b.fc_rx);
    let mut d = vec![kestrel_proto::messages::SECTOR_UNKNOWN; 72];
    d[0] = 250;
    let sectors = ObstacleSectors {
        distances_cm: d,
        increment_deg: 5.0,
        angle_offset_deg: 0.0,
        min_distance_cm: 20,
        max_distance_cm: 1200,
    };
    b.hub.station().on_sectors(t(10_050), &sectors);
    // 10 Hz or more for as long as the sectors are fresh: 20 Hz over 400 ms is 8 or 9.
    let mut sent = Vec::new();
    for ms in (10_060..=10_460).step_by(20) {
        b.hub.on_tick(t(ms));
        sent.extend(Bench::sent(&mut b.fc_rx).into_iter().filter_map(|(f, m)| match m {
            MavMessage::OBSTACLE_DISTANCE(o) => Some((f, o)),
            _ => None,
        }));
    }
    assert!((8..=9).contains(&sent.len()), "{}", sent.len());
    let (f, o) = &sent[0];
    assert_eq!((f.system_id, f.component_id), (1, 196));
    assert_eq!(
        (o.time_usec, o.frame, o.increment_f, o.distances[0], o.distances[1]),
        (3_050_000, MavFrame::MAV_FRAME_BODY_FRD, 5.0, 250, u16::MAX)
    );
    // Stale: nothing more.
    for ms in (10_560..=11_000).step_by(20) {
        b.hub.on_tick(t(ms));
    }
    assert!(!Bench::sent(&mut b.fc_rx).iter().any(|(_, m)| matches!(m, MavMessage::OBSTACLE_DISTANCE(_))));
}

#[test]
fn routing_as_mavlink_router_each_frame_once_and_signed_frames_unchanged() {
    let mut b = Bench::new();
    b.heartbeat(false, 0, t(10_000));
    b.feed(
        b.gcs,
        &encode(
            GCS,
            &MavMessage::HEARTBEAT(HEARTBEAT_DATA { mavtype: MavType::MAV_TYPE_GCS, ..Default::default() }),
            None,
        ),
        t(10_000),
    );
    Bench::sent(&mut b.fc_rx);
    let to_gcs = Bench::sent(&mut b.gcs_rx);
    assert_eq!(
        to_gcs.iter().filter(|(f, _)| (f.system_id, f.component_id) == (1, 1)).count(),
        1,
        "the FC's heartbeat, once"
    );
    // A ground station's command to the flight controller: to the FC once, byte for byte, and
    // unanswered by us. A signed frame (whatever its signature) is forwarded as it came.
    let arm = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        target_system: 1,
        target_component: 1,
        command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        param1: 1.0,
        ..Default::default()
    });
    let signed = signed(encode(GCS, &arm, None));
    for bytes in [encode(GCS, &arm, None), signed.clone()] {
        b.feed(b.gcs, &bytes, t(10_010));
        let got: Vec<Vec<u8>> = std::iter::from_fn(|| b.fc_rx.try_recv().ok()).collect();
        assert_eq!(got, vec![bytes.clone()], "to the flight controller once, unchanged");
        assert!(Bench::sent(&mut b.gcs_rx).is_empty(), "not answered, not echoed");
    }
    // The FC's answer goes to the ground station once and is not read as ours.
    b.fc_sends(
        MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
            command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            target_system: 255,
            target_component: 190,
            ..Default::default()
        }),
        t(10_020),
    );
    assert_eq!(Bench::sent(&mut b.gcs_rx).len(), 1);
    assert!(Bench::sent(&mut b.fc_rx).is_empty());
    // A command to the companion alone: one UNSUPPORTED answer to the GCS, not forwarded.
    let to_us = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        target_system: 1,
        target_component: 196,
        command: MavCmd::MAV_CMD_REQUEST_MESSAGE,
        ..Default::default()
    });
    b.feed(b.gcs, &encode(GCS, &to_us, None), t(10_030));
    assert!(Bench::sent(&mut b.fc_rx).is_empty(), "not forwarded to the flight controller");
    let answers = Bench::sent(&mut b.gcs_rx);
    assert_eq!(answers.len(), 1);
    assert!(
        matches!(&answers[0].1, MavMessage::COMMAND_ACK(a) if a.result == MavResult::MAV_RESULT_UNSUPPORTED && a.target_system == 255)
    );
    // Our own frames coming back (a loop) are dropped unrouted.
    let looped = encode(
        MavHeader { system_id: 1, component_id: 196, sequence: 0 },
        &b.hub.station().heartbeat().expect("known"),
        None,
    );
    b.feed(b.gcs, &looped, t(10_040));
    assert!(Bench::sent(&mut b.fc_rx).is_empty());
    assert_eq!(b.hub.stats().own_id_refused, 1);
}

/// `bytes` (an unsigned MAVLink 2 frame) marked signed, with a made-up signature: the router
/// passes signatures through without reading them.
fn signed(mut bytes: Vec<u8>) -> Vec<u8> {
    bytes[2] |= 0x01;
    let crc_end = bytes.len() - 2;
    let id = u32::from_le_bytes([bytes[7], bytes[8], bytes[9], 0]);
    let crc = mavlink::calculate_crc(&bytes[1..crc_end], MavMessage::extra_crc(id));
    bytes[crc_end..].copy_from_slice(&crc.to_le_bytes());
    bytes.extend([7u8; 13]);
    bytes
}
