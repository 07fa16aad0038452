//! Input that must not move the vehicle, flown through the commander in the closed loop (issue
//! "bad input that can hurt the vehicle"): stale sticks, a mission into the ground, GUIDED
//! targets a million metres away, and what a take-off leaves the vehicle in. NavState is the
//! simulator's truth (see `common`).

mod common;

use common::Flight;
use kestrel_control::CommanderParams;
use kestrel_proto::Time;
use kestrel_proto::messages::{
    AltitudeFrame, Command, FailsafeCause, FlightMode, LandedState, ManualControl, Mission, MissionItem,
    MissionPoint,
};

fn why(r: Result<(), kestrel_control::Refusal>) -> String {
    r.expect_err("should be refused").0
}

/// A waypoint `north_m` north of home at `alt_m` above it.
fn waypoint(f: &Flight, north_m: f64, alt_m: f64) -> MissionItem {
    let home = f.l.sim.world().home.geodetic();
    MissionItem::Waypoint {
        point: MissionPoint {
            lat_deg: home.lat_deg + north_m / 110_574.0,
            lon_deg: home.lon_deg,
            alt_m,
            frame: AltitudeFrame::RelativeHome,
        },
        acceptance_radius_m: 1.0,
        hold_s: 0.0,
    }
}

#[test]
fn sticks_heard_once_and_then_silent_fly_nothing() {
    let mut f = Flight::new(CommanderParams::default());
    let full = ManualControl {
        time: f.now(),
        roll: 1.0,
        pitch: 1.0,
        yaw: 1.0,
        throttle: 0.0,
        ..ManualControl::default()
    };
    f.commander.on_manual(&full);
    f.command(Command::SetMode(FlightMode::Acro)).expect("fresh sticks: ACRO may be entered");
    f.command(Command::SetMode(FlightMode::PosHold)).expect("poshold");
    f.run(15.0);
    // Fifteen seconds later (ground station heartbeats or not) the sticks are gone.
    assert!(why(f.command(Command::SetMode(FlightMode::Acro))).contains("manual control"));
    assert!(why(f.command(Command::SetMode(FlightMode::Stabilize))).contains("manual control"));
    f.commander.on_manual(&ManualControl { time: Time::ZERO, ..full });
    assert!(why(f.command(Command::SetMode(FlightMode::Acro))).contains("manual control"), "old stamp");
}

#[test]
fn losing_the_sticks_in_poshold_returns_home_and_lands() {
    let mut f = Flight::new(CommanderParams::default());
    f.sticks = Some(ManualControl { time: f.now(), throttle: 0.5, ..ManualControl::default() });
    f.command(Command::SetMode(FlightMode::PosHold)).expect("poshold");
    f.command(Command::Arm).expect("armed");
    // Throttle up to climb, then forward at full stick.
    f.sticks = Some(ManualControl { time: f.now(), throttle: 1.0, ..ManualControl::default() });
    assert!(f.run_until(10.0, |f| f.height() > 6.0), "climbed");
    f.sticks = Some(ManualControl { time: f.now(), pitch: 1.0, throttle: 0.5, ..ManualControl::default() });
    f.run(2.0);
    let moving = f.l.sim.state().velocity_ned_m_s.x;
    assert!(moving > 2.0, "flying forward at {moving} m/s");
    // The radio stops with the stick still forward.
    f.sticks = None;
    f.run(0.5);
    assert_eq!(f.commander.mode(), FlightMode::PosHold, "within the timeout nothing happens yet");
    assert!(f.run_until(1.0, |f| f.commander.mode() == FlightMode::ReturnToLaunch), "no failsafe");
    assert_eq!(f.commander.failsafe_log()[0].cause, FailsafeCause::ManualControlLost);
    assert!(f.run_until(90.0, |f| !f.commander.armed()), "did not land");
    assert!(f.l.sim.landed() && !f.l.sim.crashed());
    assert!(f.l.position().xy().norm() < 1.0, "landed at {}", f.l.position());
}

#[test]
fn stale_sticks_are_centred_not_flown() {
    // The failsafe only warns here, so what the mode itself flies on stale sticks shows.
    let mut params = CommanderParams::default();
    params.failsafe.manual_action = kestrel_proto::messages::FailsafeAction::Warn;
    let mut f = Flight::new(params);
    f.sticks = Some(ManualControl { time: f.now(), throttle: 0.0, ..ManualControl::default() });
    f.run(0.05);
    f.command(Command::SetMode(FlightMode::AltHold)).expect("althold");
    f.command(Command::Arm).expect("armed with the throttle low");
    f.sticks = Some(ManualControl { time: f.now(), throttle: 1.0, ..ManualControl::default() });
    assert!(f.run_until(10.0, |f| f.height() > 5.0), "climbed");
    // Full climb stick, then silence: after the timeout the vehicle must stop climbing.
    f.sticks = None;
    f.run(3.0);
    let climb = -f.l.sim.state().velocity_ned_m_s.z;
    assert!(climb.abs() < 0.3, "still climbing at {climb} m/s on sticks 3 s old");
    assert_eq!(f.commander.mode(), FlightMode::AltHold);
    assert_eq!(f.commander.failsafe_log()[0].cause, FailsafeCause::ManualControlLost);
}

#[test]
fn a_mission_into_the_ground_is_refused_at_start_naming_the_item() {
    let mut f = Flight::new(CommanderParams::default());
    let items = vec![waypoint(&f, 10.0, 10.0), waypoint(&f, 20.0, -500.0)];
    let mission = Mission { time: f.now(), items, cruise_speed_m_s: 5.0 };
    f.commander.on_mission(mission).expect("well-formed: kept");
    let upload = f.commander.status(f.now()).last_refusal.expect("said on upload");
    assert!(upload.starts_with("mission item 2: -500.0 m above home"), "{upload}");
    let start = why(f.command(Command::SetMode(FlightMode::Auto)));
    assert!(start.contains("mission item 2"), "{start}");
    f.command(Command::SetMode(FlightMode::Guided)).expect("guided");
    f.command(Command::Arm).expect("armed");
    assert!(why(f.command(Command::MissionStart)).contains("mission item 2"));
}

#[test]
fn a_vehicle_on_the_ground_in_auto_is_detected_as_landed_and_disarms() {
    // The feasibility check switched off (a least height far below home) to fly what it refuses.
    let mut params = CommanderParams::default();
    params.feasibility.min_height_m = -100.0;
    let mut f = Flight::new(params);
    let items = vec![waypoint(&f, 5.0, 5.0), waypoint(&f, 10.0, -50.0), waypoint(&f, 20.0, 10.0)];
    f.commander.on_mission(Mission { time: f.now(), items, cruise_speed_m_s: 3.0 }).expect("mission");
    f.command(Command::SetMode(FlightMode::Auto)).expect("auto");
    f.command(Command::Arm).expect("armed");
    assert!(f.run_until(20.0, |f| f.commander.landed() == LandedState::InAir), "took off");
    assert!(f.run_until(60.0, |f| !f.commander.armed()), "sat armed on the ground");
    let status = f.commander.status(f.now());
    assert_eq!(status.landed, LandedState::OnGround);
    assert!(!status.mission.completed, "{status:?}");
    assert_eq!(status.mission.current, 1, "stuck on the item below ground");
    assert!(f.l.sim.landed());
}

#[test]
fn guided_targets_beyond_the_fence_or_limits_are_refused_and_take_off_ends_in_guided() {
    let mut f = Flight::new(CommanderParams::default());
    f.command(Command::SetMode(FlightMode::Guided)).expect("guided");
    f.command(Command::Arm).expect("armed");
    f.command(Command::Takeoff { altitude_m: 5.0 }).expect("takeoff");
    assert_eq!(f.commander.mode(), FlightMode::Takeoff);
    assert!(f.run_until(15.0, |f| f.commander.mode() == FlightMode::Guided), "take-off did not end");
    assert!((f.height() - 5.0).abs() < 0.6, "at {} m", f.height());
    for target in [[1e6, 0.0, -5.0], [3.4e38, -3.4e38, -5.0], [0.0, 1e30, -5.0], [10.0, 0.0, 400.0]] {
        let r = why(f.command(Command::GotoNed { position_ned_m: target }));
        assert!(r.starts_with("guided target refused"), "{target:?}: {r}");
    }
    let r = why(f.command(Command::VelocityNed { velocity_ned_m_s: [1e30, 0.0, 0.0] }));
    assert!(r.contains("at most 12.0 m/s"), "{r}");
    // GUIDED takes a sane target straight after the take-off.
    f.command(Command::GotoNed { position_ned_m: [8.0, 0.0, -5.0] }).expect("goto");
    assert!(f.run_until(15.0, |f| (f.l.position().x - 8.0).abs() < 0.3), "flew to the target");
    assert!(f.l.position().x < 9.0);
}
