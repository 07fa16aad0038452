//! Flight modes on the wire: ArduPilot Copter's `custom_mode` numbers.
//!
//! We announce `MAV_AUTOPILOT_ARDUPILOTMEGA` with `MAV_TYPE_QUADROTOR`, so QGroundControl,
//! Mission Planner and MAVProxy show ArduCopter's mode names and offer them for switching.
//!
//! | Kestrel `FlightMode` | custom_mode | ArduCopter name |
//! |---|---|---|
//! | Stabilize | 0 | STABILIZE |
//! | Acro | 1 | ACRO |
//! | AltHold | 2 | ALT_HOLD |
//! | Auto | 3 | AUTO |
//! | Guided, Takeoff | 4 | GUIDED (ArduCopter takes off in GUIDED) |
//! | PosHold | 5 | LOITER: stick velocity, centred holds position, as ours (POSHOLD, 16, is accepted inbound too) |
//! | ReturnToLaunch | 6 | RTL |
//! | Circle | 7 | CIRCLE (also what DO_ORBIT starts) |
//! | Land | 9 | LAND |
//! | Brake | 17 | BRAKE (MAVSDK's `hold` asks for it) |
//! | Follow | 23 | FOLLOW (MAVSDK's `follow_me.start` asks for it) |

use kestrel_proto::messages::FlightMode;

/// The `custom_mode` we report for `mode`.
pub fn custom_mode(mode: FlightMode) -> u32 {
    match mode {
        FlightMode::Stabilize => 0,
        FlightMode::Acro => 1,
        FlightMode::AltHold => 2,
        FlightMode::Auto => 3,
        FlightMode::Guided | FlightMode::Takeoff => 4,
        FlightMode::PosHold => 5,
        FlightMode::ReturnToLaunch => 6,
        FlightMode::Circle => 7,
        FlightMode::Land => 9,
        FlightMode::Brake => 17,
        FlightMode::Follow => 23,
    }
}

/// The mode a ground station asks for with `custom_mode`, if we fly it.
pub fn flight_mode(custom_mode: u32) -> Option<FlightMode> {
    Some(match custom_mode {
        0 => FlightMode::Stabilize,
        1 => FlightMode::Acro,
        2 => FlightMode::AltHold,
        3 => FlightMode::Auto,
        4 => FlightMode::Guided,
        // LOITER and POSHOLD both hold position with the sticks centred, as ours does.
        5 | 16 => FlightMode::PosHold,
        6 => FlightMode::ReturnToLaunch,
        7 => FlightMode::Circle,
        9 => FlightMode::Land,
        // MAVSDK 4's `hold` asks for BRAKE: it stops, then holds.
        17 => FlightMode::Brake,
        23 => FlightMode::Follow,
        _ => return None,
    })
}

/// ArduCopter's name of `mode`, for STATUSTEXT.
pub fn mode_name(mode: FlightMode) -> &'static str {
    match mode {
        FlightMode::Stabilize => "STABILIZE",
        FlightMode::Acro => "ACRO",
        FlightMode::AltHold => "ALT_HOLD",
        FlightMode::Auto => "AUTO",
        FlightMode::Guided => "GUIDED",
        FlightMode::Takeoff => "TAKEOFF",
        FlightMode::PosHold => "LOITER",
        FlightMode::ReturnToLaunch => "RTL",
        FlightMode::Land => "LAND",
        FlightMode::Circle => "CIRCLE",
        FlightMode::Brake => "BRAKE",
        FlightMode::Follow => "FOLLOW",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_mode_round_trips_except_takeoff_which_reads_back_as_guided() {
        for mode in [
            FlightMode::Stabilize,
            FlightMode::Acro,
            FlightMode::AltHold,
            FlightMode::PosHold,
            FlightMode::Guided,
            FlightMode::Auto,
            FlightMode::ReturnToLaunch,
            FlightMode::Land,
            FlightMode::Circle,
            FlightMode::Brake,
            FlightMode::Follow,
        ] {
            assert_eq!(flight_mode(custom_mode(mode)), Some(mode));
        }
        assert_eq!(flight_mode(custom_mode(FlightMode::Takeoff)), Some(FlightMode::Guided));
        assert_eq!((custom_mode(FlightMode::Circle), custom_mode(FlightMode::Brake)), (7, 17));
        assert_eq!(flight_mode(8), None, "DRIFT is not flown");
    }
}
