//! Failsafes: latching, clearing on disarm, the actions set live, and the battery's voltage.

use kestrel_proto::Time;
use kestrel_proto::messages::{BatteryStatus, Command, FailsafeCause, FlightMode};

use super::fixtures::{at, cmd, full_battery, nav, ready};
use crate::commander::{Commander, CommanderParams};

#[test]
fn latched_failsafes_are_cleared_on_disarm_so_the_vehicle_can_arm_again() {
    let mut c = ready(true);
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    // The estimator reports an unconverged attitude on the ground: EstimatorUnhealthy (latched,
    // LAND) disarms on the ground.
    let mut bad = nav(Time(2000), 0.0, true);
    bad.valid.attitude = false;
    c.on_nav(&bad);
    c.update(Time(2000));
    assert!(!c.armed());
    // The estimator recovers: the pre-arm checks must not be blocked by the old latch.
    c.on_nav(&nav(Time(3000), 0.0, true));
    c.on_battery(&full_battery(Time(3000)));
    c.update(Time(3000));
    assert_eq!(at(&mut c, 3000, Command::Arm), Ok(()));
}

#[test]
fn a_hold_failsafe_on_the_ground_does_not_disarm() {
    let params = CommanderParams {
        failsafe: crate::commander::FailsafeParams {
            link_action: kestrel_proto::messages::FailsafeAction::Hold,
            ..crate::commander::FailsafeParams::default()
        },
        ..CommanderParams::default()
    };
    let mut c = Commander::new(params).expect("valid");
    c.on_nav(&nav(Time(1000), 0.0, true));
    c.on_battery(&full_battery(Time(1000)));
    cmd(&mut c, Command::Heartbeat { system_id: 255 }).expect("heartbeat");
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    // The link is lost while armed on the ground: HOLD, which is weaker than RTL.
    c.on_nav(&nav(Time(6_100_000), 0.0, true));
    c.update(Time(6_100_000));
    let status = c.status(Time(6_100_000));
    assert_eq!(status.failsafe.map(|f| f.cause), Some(kestrel_proto::messages::FailsafeCause::DataLinkLost));
    assert!(c.armed(), "a HOLD failsafe disarmed on the ground");
}

#[test]
fn the_link_loss_action_set_live_is_the_one_flown() {
    // (FS_GCS_ENABLE, the mode the link loss leaves the hovering vehicle in)
    for (code, mode) in [
        (1.0, FlightMode::ReturnToLaunch),
        (5.0, FlightMode::Land),
        (7.0, FlightMode::PosHold),
        (0.0, FlightMode::Guided),
    ] {
        let mut c = ready(true);
        cmd(&mut c, Command::Heartbeat { system_id: 255 }).expect("heartbeat");
        cmd(&mut c, Command::SetMode(FlightMode::Guided)).expect("guided");
        cmd(&mut c, Command::Arm).expect("arm");
        c.on_nav(&nav(Time(2000), -5.0, true));
        c.update(Time(2000));
        assert_eq!(c.on_param("FS_GCS_ENABLE", code), Ok(crate::commander::ParamChange::Applied));
        assert!(c.on_param("FS_GCS_ENABLE", 3.0).is_err(), "SmartRTL is refused");
        c.on_nav(&nav(Time(6_100_000), -5.0, true));
        c.update(Time(6_100_000));
        let failsafe = c.status(Time(6_100_000)).failsafe.expect("link loss reported");
        assert_eq!(failsafe.cause, kestrel_proto::messages::FailsafeCause::DataLinkLost, "{code}");
        assert_eq!(c.mode(), mode, "FS_GCS_ENABLE {code}");
        assert!(c.armed(), "FS_GCS_ENABLE {code} disarmed in the air");
    }
}

#[test]
fn a_pack_voltage_under_batt_low_volt_for_the_timer_returns_and_under_batt_crt_volt_lands() {
    let params = CommanderParams {
        failsafe: crate::commander::FailsafeParams {
            battery_low_volt: 12.8,
            battery_critical_volt: 12.0,
            battery_volt_timer_s: 10.0,
            ..crate::commander::FailsafeParams::default()
        },
        ..CommanderParams::default()
    };
    let mut c = Commander::new(params).expect("valid");
    let s = |secs: f64| Time::from_micros((secs * 1e6) as u64);
    c.on_nav(&nav(s(1.0), 0.0, true));
    c.on_battery(&full_battery(s(1.0)));
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    // Charge counted full, but the voltage sags (a failing cell): 12.5 V, under the low threshold.
    let sagged = |t: f64, volts: f64| BatteryStatus { voltage_v: volts, ..full_battery(s(t)) };
    let at = |c: &mut Commander, t: f64, volts: f64| {
        c.on_nav(&nav(s(t), -5.0, true));
        c.on_battery(&sagged(t, volts));
        c.update(s(t));
        c.status(s(t)).failsafe.map(|f| f.cause)
    };
    assert_eq!(at(&mut c, 2.0, 12.5), None);
    assert_eq!(at(&mut c, 6.0, 13.5), None, "back above: the timer restarts");
    assert_eq!(at(&mut c, 7.0, 12.5), None);
    assert_eq!(at(&mut c, 16.9, 12.5), None, "under for 9.9 s");
    assert_eq!(at(&mut c, 17.0, 12.5), Some(FailsafeCause::BatteryLow));
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch);
    assert_eq!(at(&mut c, 18.0, 11.5), Some(FailsafeCause::BatteryLow), "critical needs its own 10 s");
    assert_eq!(at(&mut c, 28.0, 11.5), Some(FailsafeCause::BatteryCritical));
    assert_eq!(c.mode(), FlightMode::Land);
}
