//! MISSION_CURRENT: the mission item being flown, how many there are and the mission's state.

use kestrel_proto::messages::FlightMode;
use mavlink::dialects::ardupilotmega::{MISSION_CURRENT_DATA, MissionState};

use super::super::Snapshot;

/// MISSION_CURRENT from the stored plan's size and the commander's progress.
///
/// Item 0 is home: the commander's item i is our item i + 1. As the message defines it (and
/// ArduPilot sends it), `total` excludes home so that the last item has `seq == total`, and is
/// UINT16_MAX when no mission is stored; a finished mission stays on its last item rather than
/// one past it.
pub fn mission_current(snap: &Snapshot) -> MISSION_CURRENT_DATA {
    let progress = snap.status.as_ref().map(|s| s.mission).unwrap_or_default();
    let state = match (snap.mission_items, progress) {
        (0, _) => MissionState::MISSION_STATE_NO_MISSION,
        (_, p) if p.completed => MissionState::MISSION_STATE_COMPLETE,
        (_, p) if p.reached > 0 || snap.status.as_ref().is_some_and(|s| s.mode == FlightMode::Auto) => {
            MissionState::MISSION_STATE_ACTIVE
        }
        _ => MissionState::MISSION_STATE_NOT_STARTED,
    };
    let total = snap.mission_items.checked_sub(1).unwrap_or(u16::MAX);
    let seq = match snap.mission_items {
        0 => 0,
        _ => u16::try_from(progress.current + 1).unwrap_or(u16::MAX).min(total),
    };
    MISSION_CURRENT_DATA { seq, total, mission_state: state, ..Default::default() }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::messages::{LandedState, MissionProgress, VehicleStatus};
    use kestrel_proto::testing::vehicle_status;

    use super::*;

    #[test]
    fn mission_current_counts_items_after_home_and_never_points_past_the_last() {
        let mut snap = Snapshot::default();
        let current = |snap: &Snapshot| {
            let m = mission_current(snap);
            (m.seq, m.total, m.mission_state)
        };
        assert_eq!(current(&snap), (0, u16::MAX, MissionState::MISSION_STATE_NO_MISSION));
        snap.mission_items = 7; // home, take-off, four waypoints, RTL
        let status = |current, reached| VehicleStatus {
            mission: MissionProgress {
                current,
                reached,
                last_reached: reached.checked_sub(1),
                total: 6,
                completed: reached >= 6,
            },
            ..vehicle_status(Time::ZERO, true, FlightMode::Auto, LandedState::InAir)
        };
        snap.status = Some(status(0, 0));
        assert_eq!(current(&snap), (1, 6, MissionState::MISSION_STATE_ACTIVE));
        snap.status = Some(status(6, 6));
        assert_eq!(
            current(&snap),
            (6, 6, MissionState::MISSION_STATE_COMPLETE),
            "finished: on the last item"
        );
    }
}
