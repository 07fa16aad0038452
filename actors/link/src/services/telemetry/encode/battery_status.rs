//! BATTERY_STATUS: the pack's voltage (mV, first cell slot: the pack's total, as ArduPilot
//! without cell monitoring), current (cA), charge drawn (mAh) and what is left (%).

use kestrel_proto::messages::BatteryStatus;
use mavlink::dialects::ardupilotmega::{BATTERY_STATUS_DATA, MavBatteryFunction, MavBatteryType};

/// BATTERY_STATUS from the battery monitor's `b`; unknown fields carry MAVLink's "unknown".
pub fn battery_status(b: &BatteryStatus) -> BATTERY_STATUS_DATA {
    let mut voltages = [u16::MAX; 10];
    voltages[0] = (b.voltage_v * 1000.0).clamp(0.0, 65_534.0) as u16;
    BATTERY_STATUS_DATA {
        current_consumed: b.consumed_mah.round() as i32,
        energy_consumed: -1,
        temperature: i16::MAX,
        voltages,
        current_battery: (b.current_a * 100.0).round() as i16,
        battery_function: MavBatteryFunction::MAV_BATTERY_FUNCTION_ALL,
        mavtype: MavBatteryType::MAV_BATTERY_TYPE_LIPO,
        battery_remaining: (b.remaining * 100.0).round().clamp(0.0, 100.0) as i8,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn volts_amps_and_charge_go_out_in_millivolts_centiamps_and_percent() {
        let b = BatteryStatus {
            voltage_v: 15.2,
            current_a: 12.3,
            consumed_mah: 812.4,
            remaining: 0.634,
            time: kestrel_proto::Time::ZERO,
        };
        let m = battery_status(&b);
        assert_eq!((m.voltages[0], m.voltages[1]), (15_200, u16::MAX));
        assert_eq!((m.current_battery, m.current_consumed, m.battery_remaining), (1230, 812, 63));
        assert_eq!((m.energy_consumed, m.temperature), (-1, i16::MAX), "unknown, not zero");
    }
}
