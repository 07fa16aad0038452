//! The flight controller's telemetry the companion needs, asked for with
//! MAV_CMD_SET_MESSAGE_INTERVAL (ArduPilot 4.x and PX4 both honour it per message; ArduPilot
//! also takes REQUEST_DATA_STREAM, but only by stream groups). A message not heard for three of
//! its periods is asked for again, at most once per [`RETRY`] (or five periods for slow ones):
//! the flight controller may have rebooted, or — on ArduPilot, whose rates are per link — a
//! ground station's REQUEST_DATA_STREAM on the same link may have slowed it.

use std::time::Duration;

use kestrel_proto::Time;
use mavlink::MessageData;
use mavlink::dialects::ardupilotmega::{
    ATTITUDE_QUATERNION_DATA, COMMAND_LONG_DATA, EXTENDED_SYS_STATE_DATA, GLOBAL_POSITION_INT_DATA,
    HOME_POSITION_DATA, LOCAL_POSITION_NED_DATA, MavCmd, MavMessage,
};

/// Shortest time between two requests for one message.
pub const RETRY: Duration = Duration::from_secs(1);

/// The messages asked for and their periods.
pub const WANTED: [(u32, Duration); 5] = [
    (ATTITUDE_QUATERNION_DATA::ID, Duration::from_millis(20)),
    (LOCAL_POSITION_NED_DATA::ID, Duration::from_millis(50)),
    (GLOBAL_POSITION_INT_DATA::ID, Duration::from_millis(200)),
    (EXTENDED_SYS_STATE_DATA::ID, Duration::from_millis(500)),
    (HOME_POSITION_DATA::ID, Duration::from_secs(1)),
];

/// When each wanted message was last heard and last asked for.
#[derive(Debug, Default)]
pub struct StreamRequests {
    heard: [Option<Time>; WANTED.len()],
    asked: [Option<Time>; WANTED.len()],
    /// Requests sent so far.
    pub sent: u64,
}

impl StreamRequests {
    /// Nothing heard or asked yet.
    pub fn new() -> StreamRequests {
        StreamRequests::default()
    }

    /// A message with id `id` came from the flight controller at `now`.
    pub fn heard(&mut self, id: u32, now: Time) {
        if let Some(i) = WANTED.iter().position(|(w, _)| *w == id) {
            self.heard[i] = Some(now);
        }
    }

    /// The requests due at `now` for the flight controller `target` (system, component).
    pub fn due(&mut self, now: Time, target: (u8, u8)) -> Vec<MavMessage> {
        let mut out = Vec::new();
        for (i, (id, period)) in WANTED.iter().enumerate() {
            let quiet = (*period * 3).max(Duration::from_millis(300));
            let retry = RETRY.max(*period * 5);
            let missing = self.heard[i].is_none_or(|t| now.saturating_since(t) > quiet);
            let may_ask = self.asked[i].is_none_or(|t| now.saturating_since(t) >= retry);
            if missing && may_ask {
                self.asked[i] = Some(now);
                self.sent += 1;
                out.push(MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
                    target_system: target.0,
                    target_component: target.1,
                    command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                    confirmation: 0,
                    param1: *id as f32,
                    param2: period.as_micros() as f32,
                    ..Default::default()
                }));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn asked_ids(out: &[MavMessage]) -> Vec<u32> {
        out.iter()
            .map(|m| match m {
                MavMessage::COMMAND_LONG(c) => {
                    assert_eq!(
                        (c.command, c.target_system, c.target_component),
                        (MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, 1, 1)
                    );
                    c.param1 as u32
                }
                other => panic!("{other:?}"),
            })
            .collect()
    }

    #[test]
    fn everything_is_asked_once_then_only_what_stays_quiet_and_not_faster_than_the_retry() {
        let mut s = StreamRequests::new();
        let t = |ms: u64| Time::from_micros(ms * 1000);
        let first = s.due(t(1000), (1, 1));
        assert_eq!(asked_ids(&first), WANTED.map(|(id, _)| id).to_vec());
        if let MavMessage::COMMAND_LONG(c) = &first[0] {
            assert_eq!(c.param2, 20_000.0, "ATTITUDE_QUATERNION every 20 000 us");
        }
        assert!(s.due(t(1500), (1, 1)).is_empty(), "not again within RETRY");
        for ms in (1500..2100).step_by(20) {
            s.heard(ATTITUDE_QUATERNION_DATA::ID, t(ms));
            s.heard(LOCAL_POSITION_NED_DATA::ID, t(ms));
        }
        // Past RETRY: the quiet ones are asked again, the streaming ones are not.
        assert_eq!(asked_ids(&s.due(t(2100), (1, 1))), vec![GLOBAL_POSITION_INT_DATA::ID]);
        assert_eq!(
            asked_ids(&s.due(t(3600), (1, 1))),
            vec![
                ATTITUDE_QUATERNION_DATA::ID,
                LOCAL_POSITION_NED_DATA::ID,
                GLOBAL_POSITION_INT_DATA::ID,
                EXTENDED_SYS_STATE_DATA::ID,
            ],
            "the attitude went quiet; HOME_POSITION waits five periods"
        );
    }
}
