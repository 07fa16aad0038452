//! The pre-arm checks and the boot mode: what arms, what is refused and why.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    BatteryStatus, Command, FlightMode, ManualControl, SetpointTarget, VehicleCommand,
};

use super::fixtures::{cmd, nav, ready};
use crate::commander::{Commander, CommanderParams};

#[test]
fn arming_checks_refuse_with_reasons() {
    let mut c = Commander::new(CommanderParams::default()).expect("valid");
    assert!(cmd(&mut c, Command::Arm).expect_err("no nav").contains("navigation"));
    c.on_nav(&nav(Time(1000), 0.0, true));
    assert!(cmd(&mut c, Command::SetMode(FlightMode::PosHold)).is_ok());
    assert!(cmd(&mut c, Command::Arm).expect_err("no battery").contains("battery"));
    c.on_battery(&BatteryStatus {
        time: Time(1000),
        voltage_v: 14.0,
        current_a: 1.0,
        consumed_mah: 0.0,
        remaining: 0.2,
    });
    assert!(cmd(&mut c, Command::Arm).expect_err("low battery").contains("20 %"));
    c.on_battery(&BatteryStatus {
        time: Time(1000),
        voltage_v: 16.0,
        current_a: 1.0,
        consumed_mah: 0.0,
        remaining: 0.9,
    });
    let mut tilted = nav(Time(1000), 0.0, true);
    tilted.attitude = [0.8, 0.6, 0.0, 0.0];
    c.on_nav(&tilted);
    assert!(cmd(&mut c, Command::Arm).expect_err("tilted").contains("level"));
    c.on_nav(&nav(Time(1000), 0.0, true));
    assert_eq!(cmd(&mut c, Command::Arm), Ok(()));
    assert_eq!(cmd(&mut c, Command::Arm), Ok(()), "arming again is done: a retry hears ACCEPTED");
    // Stale navigation is refused too.
    let mut c = ready(true);
    c.on_command(&VehicleCommand {
        id: 0,
        time: Time(1_000_000),
        command: Command::SetMode(FlightMode::Land),
    })
    .ok();
    let late = c.on_command(&VehicleCommand { id: 0, time: Time(1_000_000), command: Command::Arm });
    assert!(late.expect_err("stale").0.contains("navigation"));
}

#[test]
fn disarmed_means_motors_off_and_armed_on_the_ground_idles_in_position_modes() {
    let mut c = ready(true);
    assert_eq!(c.update(Time(1000)).target, SetpointTarget::MotorsOff);
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    let sp = c.update(Time(1000));
    assert!(sp.armed && sp.target == SetpointTarget::MotorsOff);
    cmd(&mut c, Command::Takeoff { altitude_m: 8.0 }).expect("takeoff");
    let SetpointTarget::Trajectory(t) = c.update(Time(1000)).target else { panic!("trajectory expected") };
    assert_eq!(t.position_ned_m[2], Some(-8.0));
}

#[test]
fn without_sticks_it_boots_in_guided_and_a_ground_station_may_arm_there() {
    let mut c = ready(true);
    assert_eq!(c.mode(), FlightMode::Guided, "no radio heard: a mode that needs no sticks");
    assert!(c.status(Time(1000)).armable, "the pre-arm checks pass");
    assert_eq!(cmd(&mut c, Command::Arm), Ok(()));
    assert!(!c.status(Time(1000)).armable, "armed is not armable");
    // With a radio: the first sticks heard while disarmed switch to STABILIZE, as ArduCopter boots.
    let mut c = ready(true);
    c.on_manual(&ManualControl { time: Time(1000), ..ManualControl::default() });
    assert_eq!(c.mode(), FlightMode::Stabilize);
    // A mode chosen by a ground station is kept when sticks come later.
    let mut c = ready(true);
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("loiter");
    c.on_manual(&ManualControl { time: Time(1000), ..ManualControl::default() });
    assert_eq!(c.mode(), FlightMode::PosHold);
}

#[test]
fn arming_is_refused_in_rtl_and_land_with_a_reason() {
    for mode in [FlightMode::ReturnToLaunch, FlightMode::Land] {
        let mut c = ready(true);
        cmd(&mut c, Command::SetMode(mode)).expect("mode");
        let why = cmd(&mut c, Command::Arm).expect_err("refused");
        assert!(why.contains("not in") && why.contains("GUIDED"), "{mode:?}: {why}");
        assert!(c.status(Time(1000)).armable, "the vehicle itself is ready: MAVSDK switches mode first");
    }
}
