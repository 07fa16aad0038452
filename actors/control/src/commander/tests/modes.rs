//! Every mode entered from the ground and in the air, and the refusals, each with its reason.

use kestrel_proto::Time;
use kestrel_proto::messages::{
    Command, FlightMode, LandedState, ManualControl, SetpointTarget, VehicleCommand,
};

use super::fixtures::{at, cmd, hovering, mission, nav, ready};

const ALL_MODES: [FlightMode; 9] = [
    FlightMode::Stabilize,
    FlightMode::Acro,
    FlightMode::AltHold,
    FlightMode::PosHold,
    FlightMode::Guided,
    FlightMode::Auto,
    FlightMode::Takeoff,
    FlightMode::ReturnToLaunch,
    FlightMode::Land,
];

#[test]
fn every_mode_can_be_entered_on_the_ground_when_its_needs_are_met() {
    for mode in ALL_MODES {
        let mut c = ready(true);
        c.on_mission(mission()).expect("mission");
        c.on_manual(&ManualControl { time: Time(1000), ..ManualControl::default() });
        assert_eq!(cmd(&mut c, Command::SetMode(mode)), Ok(()), "{mode:?}");
        assert_eq!(c.mode(), mode);
    }
}

#[test]
fn modes_refuse_with_a_reason_when_their_needs_are_missing() {
    let expectations = [
        (FlightMode::Stabilize, Some("manual control")),
        (FlightMode::Acro, Some("manual control")),
        (FlightMode::AltHold, Some("manual control")),
        (FlightMode::PosHold, Some("position estimate")),
        (FlightMode::Guided, Some("position estimate")),
        (FlightMode::Auto, Some("position estimate")),
        (FlightMode::Takeoff, Some("position estimate")),
        (FlightMode::ReturnToLaunch, Some("position estimate")),
        (FlightMode::Land, None),
    ];
    for (mode, reason) in expectations {
        let mut c = ready(false);
        let result = cmd(&mut c, Command::SetMode(mode));
        match reason {
            None => assert_eq!(result, Ok(()), "{mode:?}"),
            Some(r) => {
                let why = result.expect_err("refused");
                assert!(why.contains(r), "{mode:?}: {why}");
                assert_eq!(c.status(Time(1000)).last_refusal.as_deref(), Some(why.as_str()));
            }
        }
    }
}

#[test]
fn in_the_air_every_mode_switch_works_and_landing_disarms() {
    for mode in ALL_MODES {
        let mut c = ready(true);
        c.on_mission(mission()).expect("mission");
        c.on_manual(&ManualControl { time: Time(1000), throttle: 0.0, ..ManualControl::default() });
        cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
        cmd(&mut c, Command::Arm).expect("arm");
        c.on_nav(&nav(Time(2000), -5.0, true));
        c.update(Time(2000));
        assert_eq!(c.landed(), LandedState::InAir);
        c.on_command(&VehicleCommand { id: 0, time: Time(2000), command: Command::SetMode(mode) })
            .expect("switch");
        let sp = c.update(Time(2000));
        assert!(sp.armed, "{mode:?}");
        assert_ne!(sp.target, SetpointTarget::MotorsOff, "{mode:?}");
    }
    let mut c = ready(true);
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    c.on_nav(&nav(Time(2000), -5.0, true));
    c.update(Time(2000));
    c.on_command(&VehicleCommand { id: 0, time: Time(2000), command: Command::Land }).expect("land");
    let mut t = 2000;
    while c.armed() && t < 3_000_000 {
        t += 2500;
        c.on_nav(&nav(Time(t), 0.0, true));
        c.update(Time(t));
    }
    assert!(!c.armed(), "land detector did not disarm");
    assert!(t >= 1_000_000, "disarmed before the detection time");
}

#[test]
fn re_sending_the_active_mode_does_not_re_enter_it() {
    let mut c = hovering();
    at(&mut c, 2000, Command::Land).expect("land");
    // Standing still (the ground holds it) for 0.6 s, then LAND again, then 0.5 s more: the
    // land detector keeps its history and disarms at 1 s.
    let mut t = 2000;
    while t < 1_102_000 {
        t += 2500;
        c.on_nav(&nav(Time(t), 0.0, true));
        c.update(Time(t));
        if t == 602_000 {
            assert_eq!(at(&mut c, t, Command::Land), Ok(()));
        }
    }
    assert!(!c.armed(), "re-sending LAND restarted the land detector");
    // RTL in its landing phase stays there when RTL is sent again.
    let mut c = hovering();
    at(&mut c, 2000, Command::ReturnToLaunch).expect("rtl");
    c.latched.rtl = crate::commander::modes::RtlPhase::Land;
    c.on_nav(&nav(Time(4500), -5.0, true));
    c.update(Time(4500));
    assert_eq!(c.landed(), LandedState::Landing);
    assert_eq!(at(&mut c, 4500, Command::SetMode(FlightMode::ReturnToLaunch)), Ok(()));
    c.on_nav(&nav(Time(7000), -5.0, true));
    c.update(Time(7000));
    assert_eq!(c.latched.rtl, crate::commander::modes::RtlPhase::Land, "RTL climbed again");
    assert_eq!(c.landed(), LandedState::Landing);
}
