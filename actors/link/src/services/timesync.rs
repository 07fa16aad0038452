//! TIMESYNC (mavlink.io "Time Synchronization"): a request (`tc1` 0) is answered at once with our
//! time in `tc1` (ns since boot) and the requester's `ts1` mirrored, addressed back to it, as
//! ArduPilot's `GCS_MAVLINK::handle_timesync` answers; the requester pairs the two to learn the
//! offset and the round-trip time. A response (`tc1` set) to a request of someone else's is no
//! business of ours and is not answered (answering answers would ping-pong forever).

use kestrel_proto::Time;
use mavlink::dialects::ardupilotmega::{MavMessage, TIMESYNC_DATA};

use super::Sender;

/// The answer to `request` from `from` at `now`, or `None` when it is itself an answer.
pub fn answer(from: Sender, request: &TIMESYNC_DATA, now: Time) -> Option<MavMessage> {
    (request.tc1 == 0).then(|| {
        MavMessage::TIMESYNC(TIMESYNC_DATA {
            tc1: i64::try_from(now.as_micros()).unwrap_or(i64::MAX / 1000).saturating_mul(1000),
            ts1: request.ts1,
            target_system: from.target_system(),
            target_component: from.component_id,
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GCS: Sender = Sender { system_id: 255, component_id: 190 };

    #[test]
    fn a_request_is_answered_with_our_time_in_nanoseconds_and_its_own_mirrored() {
        let request = TIMESYNC_DATA { tc1: 0, ts1: 123_456_789, ..Default::default() };
        let Some(MavMessage::TIMESYNC(t)) = answer(GCS, &request, Time::from_micros(2_500_000)) else {
            panic!("a request is answered")
        };
        assert_eq!(
            (t.tc1, t.ts1, t.target_system, t.target_component),
            (2_500_000_000, 123_456_789, 255, 190)
        );
    }

    #[test]
    fn an_answer_is_not_answered() {
        let response = TIMESYNC_DATA { tc1: 42, ts1: 7, ..Default::default() };
        assert!(answer(GCS, &response, Time::from_micros(1)).is_none());
    }
}
