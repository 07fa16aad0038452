//! Who is in control, flown through the commander in the closed loop: the receiver against a
//! ground station's MAVLink sticks, `MAV_GCS_SYSID` against another ground station, and arming
//! on live sticks only (the commander's `pilot_input`). NavState is the simulator's truth.

mod common;

use common::Flight;
use kestrel_control::CommanderParams;
use kestrel_proto::messages::{Command, FailsafeCause, FlightMode, ManualControl, StickSource};

const GCS: StickSource = StickSource::Mavlink { system_id: 255 };
const OTHER_GCS: StickSource = StickSource::Mavlink { system_id: 254 };

fn sticks(pitch: f64, throttle: f64, source: StickSource) -> ManualControl {
    ManualControl { pitch, throttle, source, ..ManualControl::default() }
}

fn cause(f: &Flight) -> Option<FailsafeCause> {
    f.commander.status(f.now()).failsafe.map(|s| s.cause)
}

/// Armed in POSHOLD on `pilot`'s sticks (throttle low), climbed to about 5 m and held.
fn hovering_in_poshold(f: &mut Flight, pilot: fn(&mut Flight, ManualControl)) {
    f.command(Command::SetMode(FlightMode::PosHold)).expect("poshold");
    pilot(f, sticks(0.0, 0.0, StickSource::Radio));
    f.run(0.2);
    f.command(Command::Arm).expect("armed");
    pilot(f, sticks(0.0, 1.0, StickSource::Radio));
    assert!(f.run_until(10.0, |f| f.height() > 5.0), "climbed");
    pilot(f, sticks(0.0, 0.5, StickSource::Radio));
    f.run(1.0);
}

fn radio(f: &mut Flight, s: ManualControl) {
    f.sticks = Some(s);
}

fn ground_station(f: &mut Flight, s: ManualControl) {
    f.gcs_sticks = Some(ManualControl { source: GCS, ..s });
}

#[test]
fn one_stale_mavlink_deflection_arms_nothing_and_live_low_sticks_arm_acro() {
    let mut f = Flight::new(CommanderParams::default());
    // One full-deflection MANUAL_CONTROL, then 8 s of silence.
    let full = ManualControl { roll: 1.0, pitch: 1.0, yaw: 1.0, throttle: 1.0, source: GCS, time: f.now() };
    f.commander.on_manual(&full);
    f.run(8.0);
    let why = f.command(Command::SetMode(FlightMode::Acro)).expect_err("stale sticks");
    assert!(why.0.contains("manual control"), "{why}");
    // Booted on those sticks in STABILIZE: arming there is refused, naming why.
    assert_eq!(f.commander.mode(), FlightMode::Stabilize);
    let why = f.command(Command::Arm).expect_err("stale sticks").0;
    assert_eq!(why, "Arm: Stabilize: no manual control for 8.0 s");
    assert!(!f.commander.armed());
    // Live sticks, throttle up: refused; throttle low: ACRO arms.
    f.gcs_sticks = Some(sticks(0.0, 0.6, GCS));
    f.run(0.2);
    f.command(Command::SetMode(FlightMode::Acro)).expect("live sticks");
    let why = f.command(Command::Arm).expect_err("throttle up").0;
    assert!(why.starts_with("Arm: Throttle too high"), "{why}");
    f.gcs_sticks = Some(sticks(0.0, 0.0, GCS));
    f.run(0.2);
    f.command(Command::Arm).expect("live sticks, throttle low");
    assert!(f.commander.armed());
}

#[test]
fn a_healthy_receiver_flies_and_the_ground_stations_opposite_sticks_do_not() {
    let mut f = Flight::new(CommanderParams::default());
    hovering_in_poshold(&mut f, radio);
    let start = f.l.position();
    f.sticks = Some(sticks(1.0, 0.5, StickSource::Radio));
    f.gcs_sticks = Some(sticks(-1.0, 0.5, GCS));
    f.run(3.0);
    let moved = f.l.position() - start;
    assert!(moved.x > 5.0, "the receiver's full forward did not fly: moved {moved}");
    assert_eq!(cause(&f), None);
}

#[test]
fn with_the_receiver_lost_its_failsafe_fires_although_the_ground_stations_sticks_are_live() {
    let mut f = Flight::new(CommanderParams::default());
    hovering_in_poshold(&mut f, radio);
    f.gcs_sticks = Some(sticks(0.0, 0.5, GCS));
    f.run(1.0);
    f.sticks = None;
    assert!(
        f.run_until(1.5, |f| cause(f) == Some(FailsafeCause::ManualControlLost)),
        "the ground station's sticks held off the receiver's loss"
    );
    assert_eq!(f.commander.mode(), FlightMode::ReturnToLaunch);
}

#[test]
fn only_mav_gcs_sysid_flies_and_another_ground_stations_heartbeats_hold_off_nothing() {
    let mut f = Flight::new(CommanderParams::default());
    hovering_in_poshold(&mut f, ground_station);
    let heartbeat =
        |f: &mut Flight, system_id| f.command(Command::Heartbeat { system_id }).expect("heartbeat");
    heartbeat(&mut f, 255);
    // 255 full forward, 254 full back, both at 10 Hz: the vehicle flies north.
    f.gcs_sticks = Some(sticks(1.0, 0.5, GCS));
    let start = f.l.position();
    let mut back = sticks(-1.0, 0.5, OTHER_GCS);
    for _ in 0..30 {
        back.time = f.now();
        f.commander.on_manual(&back);
        heartbeat(&mut f, 255);
        heartbeat(&mut f, 254);
        f.run(0.1);
    }
    let moved = f.l.position() - start;
    assert!(moved.x > 5.0, "MAV_GCS_SYSID's forward did not fly: moved {moved}");
    let text = f.commander.status(f.now()).last_refusal.unwrap_or_default();
    assert_eq!(text, "Sticks from sysid 254 ignored (MAV_GCS_SYSID 255)");
    // 255 falls silent (no heartbeats, no sticks); 254 goes on with both.
    f.gcs_sticks = None;
    let silent_from = f.now();
    let mut fired_at = None;
    for _ in 0..80 {
        back.time = f.now();
        f.commander.on_manual(&back);
        heartbeat(&mut f, 254);
        f.run(0.1);
        if f.commander.failsafe_log().iter().any(|r| r.cause == FailsafeCause::DataLinkLost) {
            fired_at = Some(f.now());
            break;
        }
    }
    let fired_after_s = fired_at.map(|t| t.saturating_since(silent_from).as_secs_f64());
    assert!(
        fired_after_s.is_some_and(|s| (5.0..5.3).contains(&s)),
        "the ground-station failsafe fired {fired_after_s:?} s after 255 fell silent"
    );
    assert_eq!(f.commander.mode(), FlightMode::ReturnToLaunch);
}

#[test]
fn the_receivers_sticks_do_not_hold_off_the_ground_station_failsafe() {
    let mut f = Flight::new(CommanderParams::default());
    hovering_in_poshold(&mut f, radio);
    f.command(Command::Heartbeat { system_id: 255 }).expect("heartbeat");
    let silent_from = f.now();
    assert!(f.run_until(6.0, |f| cause(f) == Some(FailsafeCause::DataLinkLost)), "no GCS failsafe");
    let after_s = f.now().saturating_since(silent_from).as_secs_f64();
    assert!((5.0..5.1).contains(&after_s), "fired {after_s} s after the last heartbeat");
}

#[test]
fn a_lost_receiver_refuses_arming_in_stick_modes_and_poshold_refuses_a_climbing_throttle() {
    let mut f = Flight::new(CommanderParams::default());
    f.sticks = Some(sticks(0.0, 0.0, StickSource::Radio));
    f.run(0.5);
    f.sticks = None;
    f.gcs_sticks = Some(sticks(0.0, 0.0, GCS));
    f.run(1.5);
    // The ground station's live sticks may enter POSHOLD, but the receiver's loss refuses arming.
    f.command(Command::SetMode(FlightMode::PosHold)).expect("poshold");
    let why = f.command(Command::Arm).expect_err("receiver lost").0;
    assert_eq!(why, "Arm: Radio failsafe on (RC receiver lost)");
    // The receiver back, its throttle above mid-stick: POSHOLD would climb at once.
    f.sticks = Some(sticks(0.0, 0.8, StickSource::Radio));
    f.run(0.1);
    let why = f.command(Command::Arm).expect_err("climbing throttle").0;
    assert!(why.starts_with("Arm: Throttle too high"), "{why}");
    f.sticks = Some(sticks(0.0, 0.5, StickSource::Radio));
    f.run(0.1);
    f.command(Command::Arm).expect("mid-stick holds on the ground");
}
