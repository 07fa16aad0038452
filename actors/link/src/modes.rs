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
//! | PosHold | 5 | LOITER: stick velocity, centred holds position, as ours (POSHOLD, 16, and BRAKE, 17, which MAVSDK's `hold` asks for, are accepted inbound too) |
//! | ReturnToLaunch | 6 | RTL |
//! | Land | 9 | LAND |

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
        FlightMode::Land => 9,
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
        // LOITER, POSHOLD and BRAKE all hold position with the sticks centred, as ours does;
        // MAVSDK 4's `hold` asks for BRAKE.
        5 | 16 | 17 => FlightMode::PosHold,
        6 => FlightMode::ReturnToLaunch,
        9 => FlightMode::Land,
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
        ] {
            assert_eq!(flight_mode(custom_mode(mode)), Some(mode));
        }
        assert_eq!(flight_mode(custom_mode(FlightMode::Takeoff)), Some(FlightMode::Guided));
        assert_eq!(flight_mode(7), None);
    }
}
