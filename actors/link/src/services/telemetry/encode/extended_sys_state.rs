//! EXTENDED_SYS_STATE: the commander's landed state (a multirotor: no VTOL state).

use kestrel_proto::messages::{LandedState, VehicleStatus};
use mavlink::dialects::ardupilotmega::{EXTENDED_SYS_STATE_DATA, MavLandedState, MavVtolState};

/// EXTENDED_SYS_STATE from the commander's `status`.
pub fn extended_sys_state(status: &VehicleStatus) -> EXTENDED_SYS_STATE_DATA {
    EXTENDED_SYS_STATE_DATA {
        vtol_state: MavVtolState::MAV_VTOL_STATE_UNDEFINED,
        landed_state: landed_state(status.landed),
    }
}

fn landed_state(landed: LandedState) -> MavLandedState {
    match landed {
        LandedState::OnGround => MavLandedState::MAV_LANDED_STATE_ON_GROUND,
        LandedState::InAir => MavLandedState::MAV_LANDED_STATE_IN_AIR,
        LandedState::Landing => MavLandedState::MAV_LANDED_STATE_LANDING,
    }
}

#[cfg(test)]
mod tests {
    use kestrel_proto::Time;
    use kestrel_proto::messages::FlightMode;
    use kestrel_proto::testing::vehicle_status;

    use super::*;

    #[test]
    fn each_landed_state_has_its_mavlink_name() {
        for (ours, theirs) in [
            (LandedState::OnGround, MavLandedState::MAV_LANDED_STATE_ON_GROUND),
            (LandedState::InAir, MavLandedState::MAV_LANDED_STATE_IN_AIR),
            (LandedState::Landing, MavLandedState::MAV_LANDED_STATE_LANDING),
        ] {
            let s = extended_sys_state(&vehicle_status(Time::ZERO, true, FlightMode::Land, ours));
            assert_eq!(s.landed_state, theirs);
            assert_eq!(s.vtol_state, MavVtolState::MAV_VTOL_STATE_UNDEFINED);
        }
    }
}
