//! The flight controller's HEARTBEAT `custom_mode` as Kestrel's `FlightMode`.
//!
//! ArduCopter numbers its modes ([`crate::modes`]). PX4 packs `main_mode << 16 | sub_mode << 24`
//! (`px4_custom_mode.h`): MANUAL 1, ALTCTL 2, POSCTL 3, AUTO 4 (sub modes READY 1, TAKEOFF 2,
//! LOITER 3, MISSION 4, RTL 5, LAND 6), ACRO 5, OFFBOARD 6, STABILIZED 7. A mode Kestrel has no
//! name for (ArduCopter's SMART_RTL, PX4's ORBIT, ...) is `None`: no status is published for it
//! rather than a wrong one.

use kestrel_proto::messages::FlightMode;
use mavlink::dialects::ardupilotmega::MavAutopilot;

/// The mode `custom_mode` means on a flight controller of kind `autopilot`.
pub fn flight_mode(autopilot: MavAutopilot, custom_mode: u32) -> Option<FlightMode> {
    match autopilot {
        MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA => crate::modes::flight_mode(custom_mode),
        MavAutopilot::MAV_AUTOPILOT_PX4 => px4(custom_mode),
        _ => None,
    }
}

fn px4(custom_mode: u32) -> Option<FlightMode> {
    let main = (custom_mode >> 16) & 0xff;
    let sub = (custom_mode >> 24) & 0xff;
    Some(match (main, sub) {
        (1 | 7, _) => FlightMode::Stabilize,
        (2, _) => FlightMode::AltHold,
        (3, _) => FlightMode::PosHold,
        (4, 2) => FlightMode::Takeoff,
        (4, 3) => FlightMode::PosHold,
        (4, 4) => FlightMode::Auto,
        (4, 5) => FlightMode::ReturnToLaunch,
        (4, 6) => FlightMode::Land,
        (5, _) => FlightMode::Acro,
        (6, _) => FlightMode::Guided,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arducopter_and_px4_modes_read_as_kestrel_modes_and_unknown_ones_as_none() {
        let ap = MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA;
        assert_eq!(flight_mode(ap, 4), Some(FlightMode::Guided));
        assert_eq!(flight_mode(ap, 5), Some(FlightMode::PosHold));
        assert_eq!(flight_mode(ap, 21), None, "SMART_RTL");
        let px4 = MavAutopilot::MAV_AUTOPILOT_PX4;
        // PX4's AUTO.MISSION and OFFBOARD as its heartbeat carries them.
        assert_eq!(flight_mode(px4, (4 << 16) | (4 << 24)), Some(FlightMode::Auto));
        assert_eq!(flight_mode(px4, 6 << 16), Some(FlightMode::Guided));
        assert_eq!(flight_mode(px4, (4 << 16) | (9 << 24)), None, "AUTO.PRECLAND");
        assert_eq!(flight_mode(MavAutopilot::MAV_AUTOPILOT_GENERIC, 4), None);
    }
}
