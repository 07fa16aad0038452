//! The mode state machine without physics: every mode entered from the ground and in the air,
//! and the refusals, each with its reason.

use kestrel_proto::Time;
use kestrel_proto::geo::Geodetic;
use kestrel_proto::messages::{
    ActuatorOutputs, AltitudeFrame, BatteryStatus, Command, EscTelemetry, FailsafeAction, FlightMode,
    LandedState, ManualControl, Mission, MissionItem, MissionPoint, NavState, NavValidity,
    RangefinderOrientation, RangefinderSample, SetpointTarget, VehicleCommand, VerticalLimitKind,
};

use super::{Commander, CommanderParams};

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

/// A still, level NavState `down_m` (NED) at home, with or without a horizontal position.
pub(super) fn nav(t: Time, down_m: f64, position: bool) -> NavState {
    NavState {
        time: t,
        attitude: [1.0, 0.0, 0.0, 0.0],
        angular_velocity_rad_s: [0.0; 3],
        velocity_ned_m_s: [0.0; 3],
        position_ned_m: [0.0, 0.0, down_m],
        gyro_bias_rad_s: [0.0; 3],
        accel_bias_m_s2: [0.0; 3],
        covariance_diagonal: [0.0; 16],
        origin: position.then_some(Geodetic { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 20.0 }),
        valid: NavValidity {
            attitude: true,
            horizontal_velocity: position,
            horizontal_velocity_from_drag: false,
            horizontal_position: position,
            vertical_velocity: true,
            vertical_position: true,
        },
    }
}

fn mission() -> Mission {
    let point =
        MissionPoint { lat_deg: 6.7972, lon_deg: 79.9017, alt_m: 10.0, frame: AltitudeFrame::RelativeHome };
    Mission {
        time: Time::ZERO,
        items: vec![MissionItem::Takeoff { point }, MissionItem::ReturnToLaunch],
        cruise_speed_m_s: 5.0,
    }
}

/// A commander with fresh navigation (with or without position) and a full battery.
pub(super) fn ready(position: bool) -> Commander {
    let mut c = Commander::new(CommanderParams::default()).expect("valid");
    c.on_nav(&nav(Time(1000), 0.0, position));
    c.on_battery(&full_battery(Time(1000)));
    c
}

/// A fresh battery, as the pre-arm checks want it.
fn full_battery(time: Time) -> BatteryStatus {
    BatteryStatus { time, voltage_v: 16.4, current_a: 1.0, consumed_mah: 0.0, remaining: 1.0 }
}

fn cmd(c: &mut Commander, command: Command) -> Result<(), String> {
    c.on_command(&VehicleCommand { id: 0, time: Time(1000), command }).map_err(|r| r.0)
}

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
fn polygon_fence_inclusion() {
    let square = [[-10.0, -10.0], [-10.0, 10.0], [10.0, 10.0], [10.0, -10.0]];
    assert!(super::inside_polygon(&square, 0.0, 0.0));
    assert!(super::inside_polygon(&square, 9.9, -9.9));
    assert!(!super::inside_polygon(&square, 10.1, 0.0));
    assert!(!super::inside_polygon(&square, 0.0, -30.0));
    assert!(super::inside_polygon(&[], 1e6, 1e6), "no polygon, no limit");
}

#[test]
fn leaving_the_polygon_fence_in_flight_triggers_its_failsafe() {
    let params = CommanderParams {
        geofence: super::GeofenceParams {
            polygon: vec![[6.7970, 79.9016], [6.7970, 79.9018], [6.7972, 79.9018], [6.7972, 79.9016]],
            ..super::GeofenceParams::default()
        },
        ..CommanderParams::default()
    };
    let mut c = Commander::new(params).expect("valid");
    c.on_nav(&nav(Time(1000), 0.0, true));
    c.on_battery(&full_battery(Time(1000)));
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("inside the fence");
    let mut outside = nav(Time(2000), -5.0, true);
    outside.position_ned_m = [30.0, 0.0, -5.0];
    c.on_nav(&outside);
    c.update(Time(2000));
    let status = c.status(Time(2000));
    assert_eq!(
        status.failsafe.map(|f| f.cause),
        Some(kestrel_proto::messages::FailsafeCause::GeofenceBreach)
    );
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch);
}

#[test]
fn a_mission_ending_in_a_land_item_completes_on_touchdown() {
    let mut c = ready(true);
    let point =
        MissionPoint { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 5.0, frame: AltitudeFrame::RelativeHome };
    let mission = Mission {
        time: Time::ZERO,
        items: vec![MissionItem::Takeoff { point }, MissionItem::Land { point }],
        cruise_speed_m_s: 5.0,
    };
    c.on_mission(mission).expect("mission");
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    c.on_nav(&nav(Time(2000), -5.0, true));
    c.update(Time(2000));
    let mut t = 2000;
    while c.armed() && t < 5_000_000 {
        t += 2500;
        c.on_nav(&nav(Time(t), 0.0, true));
        c.update(Time(t));
    }
    let progress = c.status(Time(t)).mission;
    assert!(!c.armed());
    assert!(progress.completed && progress.reached == 2, "{progress:?}");
}

/// Armed in POSHOLD and in the air 5 m above home at t = 2 ms.
pub(super) fn hovering() -> Commander {
    let mut c = ready(true);
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    c.on_nav(&nav(Time(2000), -5.0, true));
    c.update(Time(2000));
    assert_eq!(c.landed(), LandedState::InAir);
    c
}

pub(super) fn at(c: &mut Commander, t: u64, command: Command) -> Result<(), String> {
    c.on_command(&VehicleCommand { id: 0, time: Time(t), command }).map_err(|r| r.0)
}

#[test]
fn a_slow_descent_demand_in_the_air_is_not_ground_contact_and_a_firm_one_against_the_ground_is() {
    // Hovering still 5 m up in GUIDED: a demand to sink at 0.15 m/s (an avoider's "under") that
    // the vehicle follows too slowly to see is no ground; 1 m/s down while standing still is.
    for (down_m_s, disarms) in [(0.15, false), (1.0, true)] {
        let mut c = hovering();
        at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
        let mut t = 2000;
        while t < 8_000_000 && c.armed() {
            t += 2500;
            if (t - 2000) % 500_000 == 0 {
                at(&mut c, t, Command::VelocityNed { velocity_ned_m_s: [0.0, 0.0, down_m_s] })
                    .expect("velocity");
            }
            c.on_nav(&nav(Time(t), -5.0, true));
            c.update(Time(t));
        }
        assert_eq!(!c.armed(), disarms, "{down_m_s} m/s down demanded: armed {}", c.armed());
    }
}

#[test]
fn a_stale_nav_state_never_lets_the_land_detector_disarm_in_the_air() {
    let mut c = hovering();
    // NavStates stop: the stale-nav failsafe lands, and the frozen (zero) velocity of the last
    // NavState must not count as standing still on the ground.
    let mut t = 2000;
    while t < 5_000_000 {
        t += 20_000;
        c.update(Time(t));
    }
    assert_eq!(c.mode(), FlightMode::Land);
    assert_eq!(c.landed(), LandedState::Landing);
    assert!(c.armed(), "disarmed in the air on a stale NavState");
    // Fresh NavStates on the ground again: detected after land_detect_s, not at once.
    let resumed = t;
    while c.armed() && t < resumed + 3_000_000 {
        t += 2500;
        c.on_nav(&nav(Time(t), 0.0, true));
        c.update(Time(t));
    }
    assert!(!c.armed(), "fresh NavStates on the ground should disarm");
    assert!(t - resumed >= 1_000_000, "detected {} µs after NavStates resumed", t - resumed);
}

/// The controller's backup attitude (a state without horizontal position) while the estimator's
/// is stale: announced once, the staleness still lands, the landing descends without a
/// horizontal target, and the land detector ends it on the backup's vertical channel.
#[test]
fn the_backup_attitude_is_flown_while_the_estimator_is_stale_and_lands_the_vehicle() {
    let mut c = hovering();
    let refusals = c.status(Time(2000)).refusals;
    // While the estimator is fresh the backup's states are ignored.
    c.on_backup_nav(&nav(Time(2500), -4.0, false));
    assert!(!c.on_backup_attitude());
    let mut t = 2000;
    let mut down = -5.0;
    let mut landing_target = None;
    while c.armed() && t < 30_000_000 {
        t += 2500;
        if t > 100_000 {
            // The estimator is gone: the backup sinks at 1 m/s to the ground at 0, then stands.
            down = f64::min(down + 0.0025, 0.0);
            let mut backup = nav(Time(t), down, false);
            backup.velocity_ned_m_s[2] = if down < 0.0 { 1.0 } else { 0.0 };
            c.on_backup_nav(&backup);
        }
        let sp = c.update(Time(t));
        if c.mode() == FlightMode::Land && c.armed() {
            landing_target = Some(sp.target);
        }
    }
    assert!(c.on_backup_attitude());
    let status = c.status(Time(t));
    assert_eq!(status.refusals, refusals + 1, "announced once: {:?}", status.last_refusal);
    assert_eq!(c.failsafe_log().first().map(|r| r.cause), Some(FailsafeCause::NavStateStale));
    assert!(!c.armed() && c.landed() == LandedState::OnGround, "landed on the backup's vertical channel");
    let Some(SetpointTarget::Trajectory(sp)) = landing_target else { panic!("{landing_target:?}") };
    assert_eq!(sp.position_ned_m[..2], [None, None], "no horizontal target without a position: {sp:?}");
    assert!(sp.velocity_ned_m_s[2].is_some_and(|v| v > 0.0), "descending: {sp:?}");
}

/// After a GPS loss the estimator measures the velocity from drag against the learnt wind; on
/// the ground that reads the wind as motion (1.5 m/s here). The land detector must leave it out
/// and end the landing on the vertical alone, or a windy touchdown would never disarm; a
/// GPS velocity that fast still keeps it from detecting.
#[test]
fn a_drag_measured_velocity_does_not_keep_the_land_detector_from_disarming() {
    for (from_drag, disarms) in [(true, true), (false, false)] {
        let mut c = hovering();
        at(&mut c, 2000, Command::SetMode(FlightMode::Land)).expect("land");
        let mut t = 2000;
        while c.armed() && t < 5_000_000 {
            t += 2500;
            let mut n = nav(Time(t), 0.0, false);
            n.velocity_ned_m_s = [0.0, 1.5, 0.0];
            n.valid.horizontal_velocity = true;
            n.valid.horizontal_velocity_from_drag = from_drag;
            c.on_nav(&n);
            c.update(Time(t));
        }
        assert_eq!(!c.armed(), disarms, "from drag {from_drag}: armed {}", c.armed());
    }
}

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
    c.rtl = super::RtlPhase::Land;
    c.on_nav(&nav(Time(4500), -5.0, true));
    c.update(Time(4500));
    assert_eq!(c.landed(), LandedState::Landing);
    assert_eq!(at(&mut c, 4500, Command::SetMode(FlightMode::ReturnToLaunch)), Ok(()));
    c.on_nav(&nav(Time(7000), -5.0, true));
    c.update(Time(7000));
    assert_eq!(c.rtl, super::RtlPhase::Land, "RTL climbed again");
    assert_eq!(c.landed(), LandedState::Landing);
}

#[test]
fn a_hold_failsafe_on_the_ground_does_not_disarm() {
    let params = CommanderParams {
        failsafe: super::FailsafeParams {
            link_action: kestrel_proto::messages::FailsafeAction::Hold,
            ..super::FailsafeParams::default()
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
        assert_eq!(c.on_param("FS_GCS_ENABLE", code), Ok(super::ParamChange::Applied));
        assert!(c.on_param("FS_GCS_ENABLE", 3.0).is_err(), "SmartRTL is refused");
        c.on_nav(&nav(Time(6_100_000), -5.0, true));
        c.update(Time(6_100_000));
        let failsafe = c.status(Time(6_100_000)).failsafe.expect("link loss reported");
        assert_eq!(failsafe.cause, kestrel_proto::messages::FailsafeCause::DataLinkLost, "{code}");
        assert_eq!(c.mode(), mode, "FS_GCS_ENABLE {code}");
        assert!(c.armed(), "FS_GCS_ENABLE {code} disarmed in the air");
    }
}

// The avoider in the loop (`avoidance` module).

use kestrel_proto::messages::{
    AvoidanceCommand, AvoidanceHealth, ClearRange, ClearRangeReason, SpeedCapStatus, TrajectorySetpoint,
};

/// A command whose view vouches for 100 m ahead: far enough that the speed cap never bites.
fn avoidance(t: u64, frd: [f64; 3], stale: bool) -> AvoidanceCommand {
    AvoidanceCommand {
        time: Time(t),
        velocity_frd_m_s: frd,
        health: AvoidanceHealth { stale, ..AvoidanceHealth::default() },
        clear_range: ClearRange { range_m: 100.0, reason: ClearRangeReason::StereoRange },
        ..AvoidanceCommand::default()
    }
}

/// `nav` at `down_m`, heading `yaw_rad`.
fn nav_heading(t: u64, down_m: f64, yaw_rad: f64) -> NavState {
    let (s, c) = (yaw_rad / 2.0).sin_cos();
    NavState { attitude: [c, 0.0, 0.0, s], ..nav(Time(t), down_m, true) }
}

fn trajectory(target: SetpointTarget) -> TrajectorySetpoint {
    match target {
        SetpointTarget::Trajectory(sp) => sp,
        other => panic!("not a trajectory: {other:?}"),
    }
}

fn velocity(sp: &TrajectorySetpoint) -> [f64; 3] {
    sp.velocity_ned_m_s.map(|v| v.expect("velocity demand"))
}

#[test]
fn frd_rotates_into_ned_with_the_heading() {
    let close = |a: nalgebra::Vector3<f64>, b: [f64; 3]| (a - nalgebra::Vector3::from(b)).norm() < 1e-12;
    assert!(close(super::frd_to_ned([1.0, 2.0, 3.0], 0.0), [1.0, 2.0, 3.0]));
    // Facing east: forward is east, right is south.
    let east = std::f64::consts::FRAC_PI_2;
    assert!(close(super::frd_to_ned([1.0, 0.0, 0.0], east), [0.0, 1.0, 0.0]));
    assert!(close(super::frd_to_ned([0.0, 1.0, -0.5], east), [-1.0, 0.0, -0.5]));
}

#[test]
fn guided_velocity_blends_the_rotated_correction_and_honours_the_climb() {
    let mut c = hovering();
    at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
    at(&mut c, 2000, Command::VelocityNed { velocity_ned_m_s: [3.0, 0.0, 0.0] }).expect("velocity");
    // Facing east at first; the avoider asks for 1 m/s to the right and 0.5 m/s up. The nose
    // turns north (the vehicle's heading follows the commanded one) before the vehicle flies.
    let mut yaw = std::f64::consts::FRAC_PI_2;
    let mut t = 2000;
    let mut sp = TrajectorySetpoint::default();
    while t < 4_000_000 {
        t += 2500;
        if (t - 2000) % 500_000 == 0 {
            // Repeated at 2 Hz, as a ground station streams it (GUIDED_TIMEOUT is 3 s).
            at(&mut c, t, Command::VelocityNed { velocity_ned_m_s: [3.0, 0.0, 0.0] }).expect("velocity");
        }
        c.on_nav(&nav_heading(t, -5.0, yaw));
        c.on_avoidance(&avoidance(t, [0.0, 1.0, -0.5], false));
        let before = sp;
        sp = trajectory(c.update(Time(t)).target);
        yaw = sp.yaw_rad.expect("yaw");
        // The demand changes at most at the acceleration limit.
        if t > 4500 {
            let dv = nalgebra::Vector3::from(velocity(&sp)) - nalgebra::Vector3::from(velocity(&before));
            assert!(dv.norm() <= 2.5 * 0.0025 + 1e-9, "{dv:?}");
        }
    }
    // Facing north, right is east.
    let v = velocity(&sp);
    assert!((v[0] - 3.0).abs() < 1e-6 && (v[1] - 1.0).abs() < 1e-6 && (v[2] + 0.5).abs() < 1e-6, "{v:?}");
    // A moving demand is flown as a velocity: the horizontal position setpoint is the
    // vehicle's (still at the origin here) plus one step of the demand, with no lead to catch
    // up on; the vertical one climbs ahead, within the 0.3 m leash.
    let p = sp.position_ned_m.map(|p| p.expect("position"));
    assert!((p[0] - 3.0 * 0.0025).abs() < 1e-4 && (p[1] - 0.0025).abs() < 1e-4, "{p:?}");
    assert!(p[2] + 5.0 < 0.0 && p[2] + 5.0 >= -0.3 - 1e-9, "{p:?}");
    // The nose turned towards the demanded direction (north).
    assert!(sp.yaw_rad.expect("yaw").abs() < 1e-6, "{:?}", sp.yaw_rad);
    assert_eq!(c.status(Time(t)).last_refusal, None);
}

#[test]
fn a_leg_descends_no_steeper_than_the_camera_sees_ahead_and_straight_down_over_its_target() {
    // From 17 m up, facing north: a GUIDED target 40 m north at 5 m, then one straight below.
    for (north_m, slope_limited) in [(40.0, true), (0.0, false)] {
        let mut c = hovering();
        at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
        at(&mut c, 2000, Command::GotoNed { position_ned_m: [north_m, 0.0, -5.0] }).expect("goto");
        let mut v = [0.0; 3];
        for k in 1..=1600 {
            let t = 2000 + k * 2500;
            // Flying the demand, so that the ground-contact check does not take a vehicle
            // that holds still under a descent demand for one on the ground.
            c.on_nav(&NavState { velocity_ned_m_s: v, ..nav_heading(t, -17.0, 0.0) });
            c.on_avoidance(&avoidance(t, [0.0; 3], false));
            v = velocity(&trajectory(c.update(Time(t)).target));
            if slope_limited {
                assert!(v[2] <= super::avoidance::DESCENT_SLOPE * v[0] + 1e-9, "{v:?} at {t} µs");
            }
        }
        // Settled: 5 m/s north and a quarter of it down; or the leg's 2 m/s straight down.
        let expected = if slope_limited { [5.0, 0.0, 1.25] } else { [0.0, 0.0, 2.0] };
        assert!(v.iter().zip(expected).all(|(v, e)| (v - e).abs() < 1e-6), "{v:?}, not {expected:?}");
    }
}

#[test]
fn a_target_a_few_decimetres_away_does_not_turn_the_nose() {
    // Facing north; a GUIDED target 0.5 m east (the drift of a take-off spot) is flown to
    // without swinging the forward camera towards it; one 10 m east turns it.
    for (east_m, turns) in [(0.5, false), (10.0, true)] {
        let mut c = hovering();
        at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
        at(&mut c, 2000, Command::GotoNed { position_ned_m: [0.0, east_m, -5.0] }).expect("goto");
        let mut sp = TrajectorySetpoint::default();
        for k in 1..=400 {
            let t = 2000 + k * 2500;
            c.on_nav(&nav_heading(t, -5.0, 0.0));
            c.on_avoidance(&avoidance(t, [0.0; 3], false));
            sp = trajectory(c.update(Time(t)).target);
        }
        let yaw = sp.yaw_rad.expect("yaw");
        assert_eq!(yaw.abs() > 0.5, turns, "{east_m} m east: yaw {yaw}");
    }
}

/// Armed in AUTO at 10 m, flying towards a waypoint about 11 m north with the avoider in the
/// loop; returns the commander and the time.
fn auto_leg() -> (Commander, u64) {
    let mut c = ready(true);
    let home =
        MissionPoint { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 10.0, frame: AltitudeFrame::RelativeHome };
    let north = MissionPoint { lat_deg: 6.79720, ..home };
    let items = vec![
        MissionItem::Takeoff { point: home },
        MissionItem::Waypoint { point: north, acceptance_radius_m: 1.0, hold_s: 0.0 },
    ];
    c.on_mission(Mission { time: Time::ZERO, items, cruise_speed_m_s: 4.0 }).expect("mission");
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    (c, 1000)
}

#[test]
fn auto_leg_flies_at_cruise_towards_the_waypoint_with_a_zero_correction() {
    let (mut c, mut t) = auto_leg();
    let mut sp = TrajectorySetpoint::default();
    while t < 3_000_000 {
        t += 2500;
        c.on_nav(&nav_heading(t, -10.0, 0.0));
        c.on_avoidance(&avoidance(t, [0.0; 3], false));
        sp = trajectory(c.update(Time(t)).target);
    }
    let v = velocity(&sp);
    assert!((v[0] - 4.0).abs() < 1e-6 && v[1].abs() < 1e-6 && v[2].abs() < 1e-6, "{v:?}");
    assert!(sp.yaw_rad.expect("yaw").abs() < 1e-9, "{:?}", sp.yaw_rad);
}

#[test]
fn a_landing_item_away_from_the_vehicle_is_approached_with_the_avoider_in_the_loop() {
    // AUTO at 10 m over home, the mission's LAND item about 11 m north: the level approach is
    // a leg the avoider steers (1 m/s to the right, east while facing north), at the GUIDED
    // speed; without the avoider it is a plain position setpoint.
    for with_avoider in [true, false] {
        let mut c = ready(true);
        let home = MissionPoint {
            lat_deg: 6.79710,
            lon_deg: 79.90170,
            alt_m: 10.0,
            frame: AltitudeFrame::RelativeHome,
        };
        let north = MissionPoint { lat_deg: 6.79720, ..home };
        let items = vec![MissionItem::Takeoff { point: home }, MissionItem::Land { point: north }];
        c.on_mission(Mission { time: Time::ZERO, items, cruise_speed_m_s: 4.0 }).expect("mission");
        cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
        cmd(&mut c, Command::Arm).expect("arm");
        let (mut t, mut sp) = (1000, TrajectorySetpoint::default());
        while t < 3_000_000 {
            t += 2500;
            c.on_nav(&nav_heading(t, -10.0, 0.0));
            if with_avoider {
                c.on_avoidance(&avoidance(t, [0.0, 1.0, 0.0], false));
            }
            sp = trajectory(c.update(Time(t)).target);
        }
        if with_avoider {
            let v = velocity(&sp);
            let guided = CommanderParams::default().guided_speed_m_s;
            assert!((v[0] - guided).abs() < 1e-2 && (v[1] - 1.0).abs() < 1e-2, "{v:?}");
        } else {
            assert_eq!(sp.velocity_ned_m_s, [None; 3], "{sp:?}");
            let p = sp.position_ned_m.map(|p| p.expect("position"));
            assert!((p[0] - 11.1).abs() < 0.2 && p[1].abs() < 1e-6 && (p[2] + 10.0).abs() < 1e-6, "{p:?}");
        }
    }
}

#[test]
fn a_stale_avoidance_stream_in_auto_slows_holds_and_says_why() {
    for stale_by_flag in [true, false] {
        let (mut c, mut t) = auto_leg();
        let step = |c: &mut Commander, t: u64, send: Option<bool>| {
            c.on_nav(&nav_heading(t, -10.0, 0.0));
            if let Some(stale) = send {
                c.on_avoidance(&avoidance(t, [0.0; 3], stale));
            }
            trajectory(c.update(Time(t)).target)
        };
        while t < 3_000_000 {
            t += 2500;
            step(&mut c, t, Some(false));
        }
        assert!(!c.avoidance_holding());
        // The stream goes stale: flagged by the avoider, or silent past avoidance_timeout_s.
        let send = if stale_by_flag { Some(true) } else { None };
        let mut speeds = Vec::new();
        let mut last = TrajectorySetpoint::default();
        while t < 6_000_000 {
            t += 2500;
            last = step(&mut c, t, send);
            let v = velocity(&last);
            speeds.push(v[0].hypot(v[1]));
        }
        // Slows (never faster than the limit allows), then holds still.
        assert!(speeds.windows(2).all(|w| w[1] <= w[0] + 1e-9), "speeds rise");
        assert!(speeds[0] > 3.9, "slows down, does not stop dead: {}", speeds[0]);
        assert_eq!(*speeds.last().unwrap(), 0.0);
        assert!(c.avoidance_holding(), "stale by flag: {stale_by_flag}");
        let why = c.status(Time(t)).last_refusal.expect("says why");
        assert!(why.contains("avoidance stale"), "{why}");
        let held = last.position_ned_m;
        assert_eq!(step(&mut c, t + 2500, send).position_ned_m, held, "holds position");
        assert_eq!(c.mode(), FlightMode::Auto);
        // Fresh again: the leg resumes.
        t += 2500;
        while t < 8_000_000 {
            t += 2500;
            last = step(&mut c, t, Some(false));
        }
        assert!(!c.avoidance_holding());
        assert!(velocity(&last)[0] > 3.9, "{:?}", velocity(&last));
    }
}

#[test]
fn avoidance_stale_past_avoidance_lost_s_lands_and_a_shorter_gap_only_holds() {
    let lost_s = CommanderParams::default().failsafe.avoidance_lost_s;
    // Stale for `gap_s` (flagged by the avoider on its staleness timer), then fresh again.
    for (gap_s, lands) in [(lost_s - 1.0, false), (lost_s + 1.0, true)] {
        let (mut c, mut t) = auto_leg();
        let mut cause = None;
        let gap = (3.0 * 1e6) as u64..((3.0 + gap_s) * 1e6) as u64;
        while t < ((5.0 + lost_s) * 1e6) as u64 {
            t += 2500;
            c.on_nav(&nav_heading(t, -10.0, 0.0));
            c.on_avoidance(&avoidance(t, [0.0; 3], gap.contains(&t)));
            c.update(Time(t));
            cause = cause.or(c.status(Time(t)).failsafe.map(|f| (f.cause, f.action, f.since)));
        }
        if lands {
            let (cause, action, since) = cause.expect("the failsafe fired");
            assert_eq!((cause, action), (FailsafeCause::AvoidanceLost, FailsafeAction::Land));
            // The last fresh command was 2.5 ms before the gap; it fires at the first update past it.
            let after_s = since.as_secs_f64() - (gap.start as f64 / 1e6 - 0.0025);
            assert!(
                after_s > lost_s && after_s < lost_s + 0.01,
                "fired {after_s} s after the last fresh command"
            );
            assert_eq!(c.mode(), FlightMode::Land);
        } else {
            assert_eq!(cause, None, "a gap shorter than avoidance_lost_s only holds");
            assert_eq!(c.mode(), FlightMode::Auto);
        }
    }
}

#[test]
fn without_avoidance_commands_auto_flies_point_to_point_as_before() {
    let (mut c, mut t) = auto_leg();
    let mut sp = TrajectorySetpoint::default();
    while t < 1_000_000 {
        t += 2500;
        c.on_nav(&nav_heading(t, -10.0, 0.0));
        sp = trajectory(c.update(Time(t)).target);
    }
    assert_eq!(sp.velocity_ned_m_s, [None; 3]);
    assert_eq!(sp.max_horizontal_speed_m_s, Some(4.0));
    assert!(sp.position_ned_m[0].expect("north") > 10.0);
}

// The avoider in POSHOLD: the pilot's stick velocity is the leg.

/// Armed in POSHOLD 5 m up, facing `yaw_rad`, at t = 2 ms.
fn poshold_facing(yaw_rad: f64) -> Commander {
    let mut c = ready(true);
    c.on_nav(&nav_heading(1000, 0.0, yaw_rad));
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    c.on_nav(&nav_heading(2000, -5.0, yaw_rad));
    c.update(Time(2000));
    assert_eq!(c.landed(), LandedState::InAir);
    c
}

fn sticks(t: u64, roll: f64, pitch: f64, yaw: f64, throttle: f64) -> ManualControl {
    ManualControl {
        time: Time(t),
        roll,
        pitch,
        yaw,
        throttle,
        source: kestrel_proto::messages::StickSource::Radio,
    }
}

/// Steps `c` every 2.5 ms for `duration_us` from `t` (µs, advanced) hovering 5 m up facing `yaw_rad` with
/// `manual` sticks and, if given, a fresh avoidance command `frd`; returns the last setpoint.
fn fly_sticks(
    c: &mut Commander,
    t: &mut u64,
    duration_us: u64,
    yaw_rad: f64,
    manual: [f64; 4],
    frd: Option<[f64; 3]>,
) -> TrajectorySetpoint {
    let [roll, pitch, yaw, throttle] = manual;
    let mut sp = TrajectorySetpoint::default();
    let until = *t + duration_us;
    while *t < until {
        *t += 2500;
        c.on_nav(&nav_heading(*t, -5.0, yaw_rad));
        c.on_manual(&sticks(*t, roll, pitch, yaw, throttle));
        if let Some(frd) = frd {
            c.on_avoidance(&avoidance(*t, frd, false));
        }
        sp = trajectory(c.update(Time(*t)).target);
    }
    sp
}

#[test]
fn poshold_forward_stick_blends_the_rotated_correction_and_the_pilot_keeps_heading_and_throttle() {
    let east = std::f64::consts::FRAC_PI_2;
    let mut c = poshold_facing(east);
    let mut t = 2000;
    // Full forward stick facing east (5 m/s east); the avoider asks for 1 m/s to the right
    // (south) and nothing vertical.
    let sp = fly_sticks(&mut c, &mut t, 3_000_000, east, [0.0, 1.0, 0.0, 0.5], Some([0.0, 1.0, 0.0]));
    let v = velocity(&sp);
    assert!((v[0] + 1.0).abs() < 1e-6 && (v[1] - 5.0).abs() < 1e-6, "{v:?}");
    // Throttle centred: the height is held (the demand settles to zero, the setpoint at 5 m).
    assert!(v[2].abs() < 1e-3, "{v:?}");
    assert!((sp.position_ned_m[2].expect("down") + 5.0).abs() < 0.01, "{:?}", sp.position_ned_m);
    // V_in is the pilot's demanded speed, not the blended one.
    assert_eq!(sp.desired_speed_m_s, Some(5.0));
    let facing = |sp: &TrajectorySetpoint| (sp.yaw_rad.expect("yaw") - east).abs() < 1e-9;
    assert!(facing(&sp), "the nose stays where the pilot put it: {:?}", sp.yaw_rad);
    // Forward and right together: the leg points south-east of the heading, the nose stays.
    let sp = fly_sticks(&mut c, &mut t, 2_000_000, east, [0.5, 1.0, 0.0, 0.5], Some([0.0, 1.0, 0.0]));
    let v = velocity(&sp);
    assert!((v[0] + 2.5 + 1.0).abs() < 1e-6 && (v[1] - 5.0).abs() < 1e-6, "{v:?}");
    assert!(facing(&sp), "{:?}", sp.yaw_rad);
    assert_eq!(sp.desired_speed_m_s, Some(5.0), "the forward part, towards what the camera sees");
    // The throttle still climbs (2.5 m/s at full stick) ...
    let sp = fly_sticks(&mut c, &mut t, 2_000_000, east, [0.0, 1.0, 0.0, 1.0], Some([0.0, 1.0, 0.0]));
    assert!((velocity(&sp)[2] + 2.5).abs() < 1e-6, "{:?}", velocity(&sp));
    // ... unless the avoider asks for a vertical correction: then it has the vertical.
    let sp = fly_sticks(&mut c, &mut t, 2_000_000, east, [0.0, 1.0, 0.0, 0.0], Some([0.0, 0.0, -0.5]));
    assert!((velocity(&sp)[2] + 0.5).abs() < 1e-6, "{:?}", velocity(&sp));
    // The yaw stick turns the nose at its rate (90 °/s at full stick), fed forward.
    let before = sp.yaw_rad.expect("yaw");
    let sp = fly_sticks(&mut c, &mut t, 500_000, east, [0.0, 1.0, 0.5, 0.5], Some([0.0; 3]));
    let turned = sp.yaw_rad.expect("yaw") - before;
    assert!((turned - 45f64.to_radians() * 0.5).abs() < 1e-3, "{turned}");
    assert!((sp.yaw_rate_rad_s - 45f64.to_radians()).abs() < 1e-12);
    assert_eq!(c.status(Time(t)).last_refusal, None);
    assert_eq!(c.mode(), FlightMode::PosHold);
}

#[test]
fn poshold_ramps_the_avoiders_brake_with_feed_forward_and_never_leads_the_vehicle() {
    let mut c = poshold_facing(0.0);
    let mut t = 2000;
    let sp = fly_sticks(&mut c, &mut t, 3_000_000, 0.0, [0.0, 1.0, 0.0, 0.5], Some([0.0; 3]));
    assert!((velocity(&sp)[0] - 5.0).abs() < 1e-6, "{:?}", velocity(&sp));
    assert_eq!(sp.acceleration_ned_m_s2, [0.0; 3], "steady: nothing to feed forward");
    // Moving, the horizontal setpoint is where the vehicle is plus one step of the demand:
    // no lead for a lagging vehicle to catch up on.
    let p = sp.position_ned_m.map(|p| p.expect("position"));
    assert!((p[0] - 5.0 * 0.0025).abs() < 1e-9 && p[1].abs() < 1e-9, "{p:?}");
    // The avoider brakes to 1 m/s forward: ramped at 2.5 m/s² as in every mode, with the
    // ramp's deceleration fed forward to the controller.
    let sp = fly_sticks(&mut c, &mut t, 2500, 0.0, [0.0, 1.0, 0.0, 0.5], Some([-4.0, 0.0, 0.0]));
    assert!((velocity(&sp)[0] - (5.0 - 2.5 * 0.0025)).abs() < 1e-6, "{:?}", velocity(&sp));
    assert!((sp.acceleration_ned_m_s2[0] + 2.5).abs() < 1e-6, "{:?}", sp.acceleration_ned_m_s2);
    let sp = fly_sticks(&mut c, &mut t, 1_600_000, 0.0, [0.0, 1.0, 0.0, 0.5], Some([-4.0, 0.0, 0.0]));
    assert!((velocity(&sp)[0] - 1.0).abs() < 1e-6, "{:?}", velocity(&sp));
}

/// Steps `c` as [`fly_sticks`] with no correction and a grid 0.1 s old at every step whose view
/// vouches for `range_m` ahead; returns the last setpoint.
fn fly_capped(
    c: &mut Commander,
    t: &mut u64,
    duration_us: u64,
    yaw_rad: f64,
    manual: [f64; 4],
    clear_range: ClearRange,
) -> TrajectorySetpoint {
    let [roll, pitch, yaw, throttle] = manual;
    let mut sp = TrajectorySetpoint::default();
    let until = *t + duration_us;
    while *t < until {
        *t += 2500;
        c.on_nav(&nav_heading(*t, -5.0, yaw_rad));
        c.on_manual(&sticks(*t, roll, pitch, yaw, throttle));
        let grid_time = Some(Time(t.saturating_sub(100_000)));
        c.on_avoidance(&AvoidanceCommand { grid_time, clear_range, ..avoidance(*t, [0.0; 3], false) });
        sp = trajectory(c.update(Time(*t)).target);
    }
    sp
}

#[test]
fn poshold_forward_speed_is_capped_to_stop_inside_the_clear_range_and_the_status_says_so() {
    let east = std::f64::consts::FRAC_PI_2;
    let mut c = poshold_facing(east);
    let mut t = 2000;
    let range = |range_m, reason| ClearRange { range_m, reason };
    // Full forward (5 m/s east) and half right (2.5 m/s south) stick; the view vouches for 4 m
    // ahead. By hand: a = 2 m/s², t = 0.1 s of grid age + 0.3 s, margin 1 m:
    // v²/4 + 0.4·v = 3 → v = −0.8 + √(0.64 + 12) = 2.7553 m/s.
    let cap = -0.8 + 12.64f64.sqrt();
    let untextured = range(4.0, ClearRangeReason::Untextured);
    let sp = fly_capped(&mut c, &mut t, 3_000_000, east, [0.5, 1.0, 0.0, 0.5], untextured);
    let v = velocity(&sp);
    assert!((v[1] - cap).abs() < 1e-6 && (v[0] + 2.5).abs() < 1e-6, "only the forward part is capped: {v:?}");
    let status = c.status(Time(t)).speed_cap.expect("a speed cap while the avoider has a say");
    assert!((status.cap_m_s - cap).abs() < 1e-9, "{status:?}");
    assert_eq!((status.range_m, status.reason, status.limiting), (4.0, ClearRangeReason::Untextured, true));
    // Room for more than the stick asks: the full stick, and the cap does not limit.
    let sp = fly_capped(
        &mut c,
        &mut t,
        2_000_000,
        east,
        [0.0, 1.0, 0.0, 0.5],
        range(20.0, ClearRangeReason::StereoRange),
    );
    assert!((velocity(&sp)[1] - 5.0).abs() < 1e-6, "{:?}", velocity(&sp));
    let status = c.status(Time(t)).speed_cap.expect("cap");
    assert!(!status.limiting && status.cap_m_s > 5.0, "{status:?}");
    // The view ahead unknown: no forward speed at all; the pilot can still slide sideways.
    let unknown = range(0.0, ClearRangeReason::UnknownAhead);
    let sp = fly_capped(&mut c, &mut t, 3_000_000, east, [0.5, 1.0, 0.0, 0.5], unknown);
    let v = velocity(&sp);
    assert!(v[1].abs() < 1e-6 && (v[0] + 2.5).abs() < 1e-6, "{v:?}");
    assert_eq!(
        c.status(Time(t)).speed_cap,
        Some(SpeedCapStatus {
            cap_m_s: 0.0,
            range_m: 0.0,
            reason: ClearRangeReason::UnknownAhead,
            limiting: true
        })
    );
    // A clear range that is no distance is ignored like a non-finite correction: the cap
    // stays that of the last good command.
    let bad = range(f64::NAN, ClearRangeReason::Obstacle);
    let sp = fly_capped(&mut c, &mut t, 200_000, east, [0.0, 1.0, 0.0, 0.5], bad);
    assert!(velocity(&sp)[1].abs() < 1e-6, "{:?}", velocity(&sp));
    // Centred sticks hold: no leg, no cap.
    fly_sticks(&mut c, &mut t, 100_000, east, [0.0, 0.0, 0.0, 0.5], Some([0.0; 3]));
    assert_eq!(c.status(Time(t)).speed_cap, None);
}

#[test]
fn poshold_sideways_or_backwards_sticks_get_no_correction_and_no_stale_hold() {
    // The camera looks ahead only: what it sees is not on a sideways or backward path.
    let mut c = poshold_facing(0.0);
    let mut t = 2000;
    let sp = fly_sticks(&mut c, &mut t, 3_000_000, 0.0, [1.0, 0.0, 0.0, 0.5], Some([-3.0, 1.0, 0.0]));
    let v = velocity(&sp);
    assert!(v[0].abs() < 1e-6 && (v[1] - 5.0).abs() < 1e-6, "{v:?}");
    assert_eq!(sp.desired_speed_m_s, Some(0.0));
    let sp = fly_sticks(&mut c, &mut t, 3_000_000, 0.0, [0.0, -1.0, 0.0, 0.5], None);
    assert!((velocity(&sp)[0] + 5.0).abs() < 1e-6, "{:?}", velocity(&sp));
    assert!(!c.avoidance_holding());
    assert_eq!(c.status(Time(t)).last_refusal, None);
}

#[test]
fn poshold_centred_sticks_hold_position_whatever_the_avoider_says() {
    for stream in [Some([0.0, 1.0, -0.5]), None] {
        let mut c = poshold_facing(0.0);
        let mut t = 2000;
        // One command makes the avoider active; then fresh corrections, or a stale stream.
        c.on_avoidance(&avoidance(t, [0.0; 3], false));
        let sp = fly_sticks(&mut c, &mut t, 3_000_000, 0.0, [0.0, 0.0, 0.0, 0.5], stream);
        assert_eq!(sp.position_ned_m, [Some(0.0), Some(0.0), Some(-5.0)], "{stream:?}");
        assert_eq!(sp.velocity_ned_m_s, [None; 3]);
        assert_eq!(sp.desired_speed_m_s, None);
        assert!(!c.avoidance_holding());
        assert_eq!(c.status(Time(t)).last_refusal, None, "holding is no refusal");
    }
}

#[test]
fn poshold_stale_avoidance_while_pushing_forward_slows_holds_and_says_why() {
    let mut c = poshold_facing(0.0);
    let mut t = 2000;
    fly_sticks(&mut c, &mut t, 3_000_000, 0.0, [0.0, 1.0, 0.0, 0.5], Some([0.0; 3]));
    // The depth stream stops while the pilot keeps pushing.
    let mut speeds = Vec::new();
    let mut last = TrajectorySetpoint::default();
    while t < 7_000_000 {
        last = fly_sticks(&mut c, &mut t, 2500, 0.0, [0.0, 1.0, 0.0, 0.5], None);
        let v = velocity(&last);
        speeds.push(v[0].hypot(v[1]));
    }
    assert!(speeds.windows(2).all(|w| w[1] <= w[0] + 1e-9), "speeds rise");
    assert!(speeds[0] > 4.9, "slows down, does not stop dead: {}", speeds[0]);
    assert_eq!(*speeds.last().unwrap(), 0.0);
    assert!(c.avoidance_holding());
    let why = c.status(Time(t)).last_refusal.expect("says why");
    assert!(why.contains("avoidance stale"), "{why}");
    let held = last.position_ned_m;
    let next = fly_sticks(&mut c, &mut t, 2500, 0.0, [0.0, 1.0, 0.0, 0.5], None);
    assert_eq!(next.position_ned_m, held, "holds position");
    // The throttle still climbs while held.
    let sp = fly_sticks(&mut c, &mut t, 2_000_000, 0.0, [0.0, 1.0, 0.0, 1.0], None);
    let v = velocity(&sp);
    assert!(v[0].hypot(v[1]) == 0.0 && (v[2] + 2.5).abs() < 1e-6, "{v:?}");
    assert_eq!(c.mode(), FlightMode::PosHold);
    // Sticks centred: an ordinary position hold.
    let sp = fly_sticks(&mut c, &mut t, 2500, 0.0, [0.0, 0.0, 0.0, 0.5], None);
    assert_eq!(sp.position_ned_m, [Some(0.0), Some(0.0), Some(-5.0)]);
    assert!(!c.avoidance_holding());
}

#[test]
fn poshold_without_an_avoider_flies_the_sticks_as_before() {
    let east = std::f64::consts::FRAC_PI_2;
    let mut c = poshold_facing(east);
    let mut t = 2000;
    let sp = fly_sticks(&mut c, &mut t, 1_000_000, east, [0.0, 1.0, 0.0, 0.5], None);
    let [vn, ve, vd] = sp.velocity_ned_m_s;
    assert!(vn.expect("north").abs() < 1e-9 && (ve.expect("east") - 5.0).abs() < 1e-9 && vd.is_none());
    assert_eq!(sp.position_ned_m, [None, None, Some(-5.0)]);
    assert_eq!((sp.desired_speed_m_s, sp.max_horizontal_speed_m_s), (None, None));
    assert!((sp.yaw_rad.expect("yaw") - east).abs() < 1e-9, "{:?}", sp.yaw_rad);
    assert_eq!(c.status(Time(t)).last_refusal, None);
}

// Ground-station commands that move the commander's references: home, the geofence switch and
// the current mission item.

use kestrel_proto::messages::FailsafeCause;

/// A point `north_m` north of the origin (about 110.6 km per degree here), `alt_m` in `frame`.
fn point_north(north_m: f64, alt_m: f64, frame: AltitudeFrame) -> MissionPoint {
    MissionPoint { lat_deg: 6.79710 + north_m / 110_600.0, lon_deg: 79.90170, alt_m, frame }
}

fn hover_at(c: &mut Commander, t: u64, position_ned_m: [f64; 3]) -> SetpointTarget {
    c.on_nav(&NavState { position_ned_m, ..nav(Time(t), position_ned_m[2], true) });
    c.update(Time(t)).target
}

#[test]
fn set_home_here_in_flight_moves_home_and_rtl_returns_there() {
    let mut c = hovering();
    let armed_home = c.status(Time(2000)).home.expect("home set at arming");
    assert_eq!(armed_home.position_ned_m, [0.0, 0.0, 0.0]);
    hover_at(&mut c, 3000, [20.0, 10.0, -5.0]);
    assert_eq!(at(&mut c, 3000, Command::SetHome { point: None }), Ok(()));
    let home = c.status(Time(3000)).home.expect("home");
    assert_eq!(home.position_ned_m, [20.0, 10.0, -5.0]);
    assert!(home.revision > armed_home.revision);
    // RTL from 50 m north of the new home climbs to 15 m above it, then heads for it.
    hover_at(&mut c, 4000, [70.0, 10.0, -5.0]);
    at(&mut c, 4000, Command::ReturnToLaunch).expect("rtl");
    hover_at(&mut c, 5000, [70.0, 10.0, -20.0]);
    let sp = trajectory(hover_at(&mut c, 6000, [70.0, 10.0, -20.0]));
    assert_eq!(sp.position_ned_m, [Some(20.0), Some(10.0), Some(-20.0)]);
}

#[test]
fn set_home_to_a_point_places_the_geofence_around_it_and_survives_arming() {
    let mut c = ready(true);
    let far = point_north(400.0, 20.0, AltitudeFrame::Amsl);
    assert_eq!(cmd(&mut c, Command::SetHome { point: Some(far) }), Ok(()));
    let home = c.home_ned().expect("home");
    assert!((home.x - 400.0).abs() < 1.0 && home.y.abs() < 0.01 && home.z.abs() < 1e-6, "{home:?}");
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    // The 300 m fence is around the new home: the vehicle, 400 m from it, is outside.
    let why = cmd(&mut c, Command::Arm).expect_err("outside the fence");
    assert!(why.contains("geofence"), "{why}");
    // Closer in, arming does not move the home the ground station set.
    let near = point_north(100.0, 20.0, AltitudeFrame::Amsl);
    cmd(&mut c, Command::SetHome { point: Some(near) }).expect("near home");
    let home = c.home_ned().expect("home");
    cmd(&mut c, Command::Arm).expect("arm");
    assert_eq!(c.home_ned(), Some(home));
    // An altitude relative to home is measured from the home now set.
    let above = point_north(100.0, 30.0, AltitudeFrame::RelativeHome);
    assert_eq!(cmd(&mut c, Command::SetHome { point: Some(above) }), Ok(()));
    assert!((c.home_ned().expect("home").z + 30.0).abs() < 1e-6);
}

#[test]
fn set_home_refuses_what_it_cannot_place_and_says_why() {
    let relative = point_north(0.0, 5.0, AltitudeFrame::RelativeHome);
    let mut no_origin = ready(false);
    let why = cmd(&mut no_origin, Command::SetHome { point: None }).expect_err("no origin");
    assert!(why.contains("origin"), "{why}");
    let mut c = ready(true);
    let cases = [
        (Some(MissionPoint { lat_deg: 95.0, ..relative }), "not a position"),
        (Some(MissionPoint { alt_m: f64::NAN, ..relative }), "not a position"),
        (Some(point_north(60_000.0, 20.0, AltitudeFrame::Amsl)), "from the origin"),
        (Some(relative), "not yet set"),
    ];
    for (point, reason) in cases {
        let why = cmd(&mut c, Command::SetHome { point }).expect_err(reason);
        assert!(why.contains(reason), "{point:?}: {why}");
        assert_eq!(c.status(Time(1000)).last_refusal.as_deref(), Some(why.as_str()));
        assert_eq!(c.home_ned(), None);
    }
    // "Here" needs a fresh position.
    let stale = c.on_command(&VehicleCommand {
        id: 0,
        time: Time(1_000_000),
        command: Command::SetHome { point: None },
    });
    assert!(stale.expect_err("stale").0.contains("position estimate"));
}

#[test]
fn the_geofence_switch_is_honoured_in_flight() {
    let mut c = hovering();
    assert!(c.status(Time(2000)).geofence_enabled);
    at(&mut c, 2000, Command::SetGeofence { enabled: false }).expect("fence off");
    hover_at(&mut c, 3000, [400.0, 0.0, -5.0]);
    let status = c.status(Time(3000));
    assert!(!status.geofence_enabled);
    assert_eq!(status.failsafe, None, "a disabled fence is not breached");
    assert_eq!(c.mode(), FlightMode::PosHold);
    // Switched on again outside it: the breach fires at once.
    at(&mut c, 3000, Command::SetGeofence { enabled: true }).expect("fence on");
    hover_at(&mut c, 4000, [400.0, 0.0, -5.0]);
    assert_eq!(c.status(Time(4000)).failsafe.map(|f| f.cause), Some(FailsafeCause::GeofenceBreach));
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch);
}

/// Three waypoints 20, 40 and 60 m north of home at 10 m.
fn three_waypoints() -> Mission {
    let wp = |north_m| MissionItem::Waypoint {
        point: point_north(north_m, 10.0, AltitudeFrame::RelativeHome),
        acceptance_radius_m: 1.0,
        hold_s: 0.0,
    };
    Mission { time: Time::ZERO, items: vec![wp(20.0), wp(40.0), wp(60.0)], cruise_speed_m_s: 5.0 }
}

fn north_target(target: SetpointTarget) -> f64 {
    trajectory(target).position_ned_m[0].expect("north target")
}

#[test]
fn a_running_mission_jumps_to_the_current_item_and_completes_from_there() {
    let mut c = ready(true);
    c.on_mission(three_waypoints()).expect("mission");
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    let first = north_target(hover_at(&mut c, 2000, [0.0, 0.0, -10.0]));
    assert!((first - 20.0).abs() < 0.5, "{first}");
    at(&mut c, 2000, Command::SetMissionCurrent { index: 2 }).expect("jump");
    assert_eq!(c.mode(), FlightMode::Auto);
    let jumped = north_target(hover_at(&mut c, 3000, [0.0, 0.0, -10.0]));
    assert!((jumped - 60.0).abs() < 0.5, "{jumped}");
    assert_eq!(c.status(Time(3000)).mission.current, 2);
    // Reaching the last item completes the mission although two were skipped.
    hover_at(&mut c, 4000, [jumped, 0.0, -10.0]);
    let progress = c.status(Time(4000)).mission;
    assert!(progress.completed, "{progress:?}");
    assert_eq!((progress.reached, progress.last_reached), (1, Some(2)));
}

#[test]
fn outside_auto_the_current_item_is_where_the_next_run_starts() {
    let mut c = ready(true);
    assert!(cmd(&mut c, Command::SetMissionCurrent { index: 0 }).expect_err("none").contains("no mission"));
    c.on_mission(three_waypoints()).expect("mission");
    let why = cmd(&mut c, Command::SetMissionCurrent { index: 3 }).expect_err("out of range");
    assert!(why.contains("past the last"), "{why}");
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::SetMissionCurrent { index: 1 }).expect("current");
    assert_eq!(c.mode(), FlightMode::PosHold, "setting the item must not start the mission");
    assert_eq!(c.status(Time(1000)).mission.current, 1);
    // AUTO then arming (what `--auto` does) both start a run: it still begins at item 1.
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    let target = north_target(hover_at(&mut c, 2000, [0.0, 0.0, -10.0]));
    assert!((target - 40.0).abs() < 0.5, "{target}");
    // Once that run has started, a later one starts over from the first item.
    at(&mut c, 2000, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    at(&mut c, 2000, Command::SetMode(FlightMode::Auto)).expect("auto again");
    let target = north_target(hover_at(&mut c, 3000, [0.0, 0.0, -10.0]));
    assert!((target - 20.0).abs() < 0.5, "{target}");
}

/// Waypoints at 10 m, `north_m` north of home each.
fn waypoints_north(north_m: &[f64]) -> Mission {
    let items = north_m
        .iter()
        .map(|&n| MissionItem::Waypoint {
            point: point_north(n, 10.0, AltitudeFrame::RelativeHome),
            acceptance_radius_m: 1.0,
            hold_s: 0.0,
        })
        .collect();
    Mission { time: Time::ZERO, items, cruise_speed_m_s: 5.0 }
}

/// three_waypoints() in AUTO, item 0 (20 m north) reached at t = 3 ms: item 1 is flown.
fn flying_item_1() -> Commander {
    let mut c = ready(true);
    c.on_mission(three_waypoints()).expect("mission");
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    hover_at(&mut c, 2000, [0.0, 0.0, -10.0]);
    hover_at(&mut c, 3000, [20.0, 0.0, -10.0]);
    let progress = c.status(Time(3000)).mission;
    assert_eq!((progress.current, progress.reached, progress.last_reached), (1, 1, Some(0)));
    c
}

#[test]
fn a_mission_uploaded_in_auto_is_flown_from_the_same_item() {
    let mut c = flying_item_1();
    // A longer mission: item 1 is now 50 m north, and is flown at once (ArduCopter restarts its
    // current command from the new mission: tests/mission_change.rs shows it in SITL).
    c.on_mission(waypoints_north(&[25.0, 50.0, 75.0, 100.0])).expect("replaced in flight");
    assert_eq!(c.mode(), FlightMode::Auto);
    let progress = c.status(Time(3000)).mission;
    assert_eq!((progress.current, progress.total, progress.reached), (1, 4, 1), "{progress:?}");
    assert!(!progress.completed);
    let target = north_target(hover_at(&mut c, 4000, [20.0, 0.0, -10.0]));
    assert!((target - 50.0).abs() < 0.5, "{target}");
    // Reaching it counts on from the items reached before (MISSION_ITEM_REACHED seq 2).
    hover_at(&mut c, 5000, [target, 0.0, -10.0]);
    let progress = c.status(Time(5000)).mission;
    assert_eq!((progress.current, progress.reached, progress.last_reached), (2, 2, Some(1)));
    let target = north_target(hover_at(&mut c, 6000, [target, 0.0, -10.0]));
    assert!((target - 75.0).abs() < 0.5, "{target}");
}

#[test]
fn a_shorter_mission_uploaded_in_auto_is_flown_from_its_last_item() {
    let mut c = flying_item_1();
    c.on_mission(waypoints_north(&[35.0])).expect("replaced in flight");
    let progress = c.status(Time(3000)).mission;
    assert_eq!((progress.current, progress.total), (0, 1), "{progress:?}");
    let target = north_target(hover_at(&mut c, 4000, [20.0, 0.0, -10.0]));
    assert!((target - 35.0).abs() < 0.5, "{target}");
    hover_at(&mut c, 5000, [35.0, 0.0, -10.0]);
    let progress = c.status(Time(5000)).mission;
    assert!(progress.completed, "{progress:?}");
    assert_eq!((progress.reached, progress.last_reached), (2, Some(0)));
    assert_eq!(c.mode(), FlightMode::Auto, "a finished mission holds in AUTO");
}

#[test]
fn a_mission_refused_in_auto_leaves_the_old_one_flown_and_one_that_cannot_be_flown_pauses() {
    let mut c = flying_item_1();
    let mut bad = waypoints_north(&[25.0, 50.0]);
    bad.cruise_speed_m_s = f64::NAN;
    let why = c.on_mission(bad).expect_err("not a number").0;
    assert!(why.contains("cruise speed"), "{why}");
    let target = north_target(hover_at(&mut c, 4000, [20.0, 0.0, -10.0]));
    assert!((target - 40.0).abs() < 0.5, "the old mission's item 1 is still flown: {target}");
    assert_eq!(c.status(Time(4000)).mission.total, 3);
    // Well-formed but below home: kept (what the ground station holds), said, and not flown.
    let mut below = waypoints_north(&[25.0, 50.0]);
    below.items[1] = MissionItem::Waypoint {
        point: point_north(50.0, -5.0, AltitudeFrame::RelativeHome),
        acceptance_radius_m: 1.0,
        hold_s: 0.0,
    };
    c.on_mission(below).expect("kept");
    let status = c.status(Time(4000));
    assert!(status.last_refusal.as_deref().is_some_and(|r| r.contains("mission item 2")), "{status:?}");
    assert_eq!((status.mission.current, status.mission.total), (1, 2));
    let held = trajectory(hover_at(&mut c, 5000, [22.0, 0.0, -10.0]));
    assert_eq!(held.position_ned_m, [Some(22.0), Some(0.0), Some(-10.0)], "paused where it was");
    assert_eq!(c.mode(), FlightMode::Auto);
}

#[test]
fn an_empty_mission_clears_on_the_ground_and_is_refused_while_flown() {
    let empty = || Mission { time: Time::ZERO, items: Vec::new(), cruise_speed_m_s: 5.0 };
    let mut c = flying_item_1();
    let why = c.on_mission(empty()).expect_err("flying it").0;
    assert!(why.contains("clear refused"), "{why}");
    assert_eq!(c.status(Time(3000)).mission.total, 3, "the flown mission stays");
    let mut c = ready(true);
    c.on_mission(three_waypoints()).expect("mission");
    c.on_mission(empty()).expect("cleared");
    assert_eq!(c.status(Time(1000)).mission.total, 0);
    let why = cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect_err("nothing to fly");
    assert!(why.contains("mission"), "{why}");
}

/// GUIDED, armed and told to take off to 5 m at t = 1 ms; then NavStates every 2.5 ms climb at
/// `climb_m_s` until `land_at_m` above home, where LAND arrives; from then on the vehicle slows
/// at 3 m/s², descends at 0.6 m/s to the ground and stands there. Returns the commander and the
/// time (µs) it disarmed, if it did within 30 s.
fn land_during_take_off(land_at_m: f64, climb_m_s: f64) -> (Commander, Option<u64>) {
    let mut c = ready(true);
    cmd(&mut c, Command::SetMode(FlightMode::Guided)).expect("guided");
    cmd(&mut c, Command::Arm).expect("arm");
    cmd(&mut c, Command::Takeoff { altitude_m: 5.0 }).expect("takeoff");
    let (mut t, mut height_m, mut up_m_s, mut landing) = (1000_u64, 0.0_f64, climb_m_s, false);
    while t < 30_000_000 {
        t += 2500;
        let dt_s = 0.0025;
        if landing {
            up_m_s = (up_m_s - 3.0 * dt_s).max(-0.6);
        }
        height_m = (height_m + up_m_s * dt_s).max(0.0);
        if height_m == 0.0 && landing {
            up_m_s = 0.0;
        }
        let mut n = nav(Time(t), -height_m, true);
        n.velocity_ned_m_s[2] = -up_m_s;
        c.on_nav(&n);
        if !landing && height_m >= land_at_m {
            assert_eq!(at(&mut c, t, Command::SetMode(FlightMode::Land)), Ok(()));
            landing = true;
        }
        c.update(Time(t));
        if !c.armed() {
            return (c, Some(t));
        }
    }
    (c, None)
}

#[test]
fn land_in_the_take_off_climb_disarms_on_the_ground_below_and_above_the_airborne_height() {
    // Above the airborne height the land detector runs; below it, the vehicle never counted as
    // flying, yet LAND must still end on the ground disarmed (as PX4 and ArduPilot do).
    for land_at_m in [2.0, 0.3] {
        let (c, disarmed) = land_during_take_off(land_at_m, 1.0);
        let Some(t) = disarmed else {
            panic!("LAND at {land_at_m} m in the climb never disarmed: {:?}, {:?}", c.mode(), c.landed())
        };
        assert_eq!(c.landed(), LandedState::OnGround);
        assert!(t > 1_000_000, "LAND at {land_at_m} m disarmed at {t} µs, before touching down");
    }
}

/// Runs the commander on the ground (fresh NavStates every 10 ms) from `from_us` to `to_us`.
fn idle_on_the_ground(c: &mut Commander, from_us: u64, to_us: u64) {
    let mut t = from_us;
    while t < to_us {
        t += 10_000;
        c.on_nav(&nav(Time(t), 0.0, true));
        c.on_battery(&full_battery(Time(t)));
        c.update(Time(t));
    }
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

#[test]
fn armed_on_the_ground_without_a_take_off_disarms_after_disarm_delay() {
    let mut c = ready(true);
    cmd(&mut c, Command::Arm).expect("arm");
    idle_on_the_ground(&mut c, 1000, 9_900_000);
    assert!(c.armed(), "before DISARM_DELAY (10 s)");
    idle_on_the_ground(&mut c, 9_900_000, 10_200_000);
    assert!(!c.armed(), "10 s armed on the ground without a take-off");
    let status = c.status(Time(10_200_000));
    assert!(status.last_refusal.as_deref().is_some_and(|r| r.contains("DISARM_DELAY")), "{status:?}");
    // 0 switches it off.
    let mut c =
        Commander::new(CommanderParams { disarm_delay_s: 0.0, ..CommanderParams::default() }).expect("valid");
    c.on_nav(&nav(Time(1000), 0.0, true));
    c.on_battery(&full_battery(Time(1000)));
    cmd(&mut c, Command::Arm).expect("arm");
    idle_on_the_ground(&mut c, 1000, 30_000_000);
    assert!(c.armed());
}

#[test]
fn a_guided_velocity_not_repeated_within_the_timeout_is_dropped_for_a_hold() {
    let mut c = hovering();
    at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
    at(&mut c, 2000, Command::VelocityNed { velocity_ned_m_s: [3.0, 0.0, 0.0] }).expect("velocity");
    let flies = |c: &mut Commander, t: u64| {
        c.on_nav(&nav(Time(t), -5.0, true));
        trajectory(c.update(Time(t)).target)
    };
    assert_eq!(velocity(&flies(&mut c, 2_900_000))[0], 3.0, "within GUIDED_TIMEOUT (3 s)");
    let refusals = c.status(Time(2_900_000)).refusals;
    let held = flies(&mut c, 3_100_000);
    assert_eq!(held.velocity_ned_m_s, [None; 3], "the stream stopped: no velocity flown");
    assert_eq!(held.position_ned_m, [Some(0.0), Some(0.0), Some(-5.0)], "held where it was");
    let status = c.status(Time(3_100_000));
    assert_eq!(status.refusals, refusals + 1);
    assert!(status.last_refusal.as_deref().is_some_and(|r| r.contains("holding")), "{status:?}");
}

#[test]
fn a_paused_mission_holds_where_it_stopped_and_continues_to_the_same_item() {
    let mut c = ready(true);
    c.on_mission(three_waypoints()).expect("mission");
    assert!(at(&mut c, 1000, Command::PauseMission).is_err(), "nothing to pause outside AUTO");
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    assert!((north_target(hover_at(&mut c, 2000, [0.0, 0.0, -10.0])) - 20.0).abs() < 0.5);
    at(&mut c, 2000, Command::PauseMission).expect("pause");
    let held = trajectory(hover_at(&mut c, 3000, [5.0, 0.0, -10.0]));
    assert_eq!(held.position_ned_m, [Some(5.0), Some(0.0), Some(-10.0)], "holds where it was paused");
    assert_eq!(c.mode(), FlightMode::Auto, "still AUTO, as ArduCopter's pause");
    at(&mut c, 3000, Command::ContinueMission).expect("continue");
    let resumed = north_target(hover_at(&mut c, 4000, [5.0, 0.0, -10.0]));
    assert!((resumed - 20.0).abs() < 0.5, "the same item: {resumed}");
}

#[test]
fn change_speed_sets_the_missions_leg_speed_within_the_limit() {
    let mut c = ready(true);
    c.on_mission(three_waypoints()).expect("mission");
    assert!(at(&mut c, 1000, Command::ChangeSpeed { speed_m_s: 3.0 }).is_err(), "AUTO only");
    cmd(&mut c, Command::SetMode(FlightMode::Auto)).expect("auto");
    cmd(&mut c, Command::Arm).expect("arm");
    let speed = |c: &mut Commander, t| trajectory(hover_at(c, t, [0.0, 0.0, -10.0])).max_horizontal_speed_m_s;
    assert_eq!(speed(&mut c, 2000), Some(5.0), "the mission's cruise speed");
    at(&mut c, 2000, Command::ChangeSpeed { speed_m_s: 2.5 }).expect("change");
    assert_eq!(speed(&mut c, 3000), Some(2.5));
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 50.0] {
        assert!(at(&mut c, 3000, Command::ChangeSpeed { speed_m_s: bad }).is_err(), "{bad}");
    }
    assert_eq!(speed(&mut c, 4000), Some(2.5), "a refused change keeps the speed");
}

#[test]
fn condition_yaw_and_a_region_of_interest_point_the_nose_in_guided() {
    let mut c = hovering();
    assert!(
        at(&mut c, 2000, Command::Yaw { heading_deg: Some(90.0), relative_deg: None }).is_err(),
        "LOITER"
    );
    at(&mut c, 2000, Command::SetMode(FlightMode::Guided)).expect("guided");
    at(&mut c, 2000, Command::Yaw { heading_deg: Some(90.0), relative_deg: None }).expect("yaw");
    let yaw = |c: &mut Commander, t| trajectory(hover_at(c, t, [0.0, 0.0, -5.0])).yaw_rad.expect("yaw");
    assert!((yaw(&mut c, 3000) - 90f64.to_radians()).abs() < 1e-9);
    // A point to the south-west: the nose turns there (atan2(east, north)).
    at(&mut c, 3000, Command::RegionOfInterest { position_ned_m: Some([-10.0, -10.0, 0.0]) }).expect("roi");
    assert!((yaw(&mut c, 4000) - (-135f64).to_radians()).abs() < 1e-9);
    for bad in [
        Command::Yaw { heading_deg: Some(f64::NAN), relative_deg: None },
        Command::Yaw { heading_deg: Some(10.0), relative_deg: Some(10.0) },
        Command::RegionOfInterest { position_ned_m: Some([f64::INFINITY, 0.0, 0.0]) },
    ] {
        assert!(at(&mut c, 4000, bad).is_err(), "{bad:?}");
    }
    at(&mut c, 4000, Command::RegionOfInterest { position_ned_m: None }).expect("roi none");
    let kept = yaw(&mut c, 5000);
    assert!((kept - (-135f64).to_radians()).abs() < 1e-9, "the last heading is held: {kept}");
}

#[test]
fn a_pack_voltage_under_batt_low_volt_for_the_timer_returns_and_under_batt_crt_volt_lands() {
    let params = CommanderParams {
        failsafe: super::FailsafeParams {
            battery_low_volt: 12.8,
            battery_critical_volt: 12.0,
            battery_volt_timer_s: 10.0,
            ..super::FailsafeParams::default()
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

/// The loop's commands and the ESCs' answer every 2.5 ms from `from_us` for `seconds`, each
/// motor commanded 0.5 and producing it, except `lost` producing `lost_thrust`; returns the
/// time reached.
fn motors_run(
    c: &mut Commander,
    from_us: u64,
    seconds: f64,
    count: u8,
    lost: usize,
    lost_thrust: f64,
) -> u64 {
    let mut t = from_us;
    while t < from_us + (seconds * 1e6) as u64 {
        t += 2500;
        let mut motors = [0.0; kestrel_proto::messages::MAX_MOTORS];
        motors[..usize::from(count)].fill(0.5);
        c.on_actuators(&ActuatorOutputs { time: Time(t), armed: true, motors });
        let mut thrust = motors;
        thrust[lost] = lost_thrust;
        c.on_esc_telemetry(&EscTelemetry { time: Time(t), count, thrust, speed_rad_s: [0.0; 8] });
        c.on_nav(&nav(Time(t), -5.0, true));
        c.update(Time(t));
    }
    t
}

#[test]
fn a_quad_motor_that_stops_is_declared_after_fd_act_mot_tout_and_lands() {
    let mut c = hovering();
    let t = motors_run(&mut c, 2000, 1.0, 4, 1, 0.5);
    assert_eq!(c.failed_motor(), None, "healthy telemetry");
    // Motor 2 produces nothing: declared once the shortfall has lasted FD_ACT_MOT_TOUT (0.1 s).
    let t = motors_run(&mut c, t, 0.095, 4, 1, 0.0);
    assert_eq!(c.failed_motor(), None, "declared before FD_ACT_MOT_TOUT");
    let t = motors_run(&mut c, t, 0.01, 4, 1, 0.0);
    assert_eq!(c.failed_motor(), Some(1));
    let sp = c.update(Time(t));
    assert_eq!(sp.failed_motor, Some(1), "the loop is told to allocate around it");
    let status = c.status(Time(t));
    assert_eq!(status.failed_motor, Some(1));
    assert_eq!(status.last_refusal.as_deref(), Some("Motor 2 failure: cannot hold yaw"));
    let f = status.failsafe.expect("a failsafe");
    assert_eq!((f.cause, f.action), (FailsafeCause::MotorFailure, FailsafeAction::Land));
    assert_eq!(c.mode(), FlightMode::Land);
    // Latched: the motor coming back does not undo the landing.
    let t = motors_run(&mut c, t, 0.5, 4, 1, 0.5);
    assert_eq!(c.failed_motor(), Some(1));
    assert_eq!(c.status(Time(t)).failsafe.map(|f| f.cause), Some(FailsafeCause::MotorFailure));
}

#[test]
fn a_hexa_motor_that_stops_is_reported_and_the_flight_goes_on() {
    let mut c = hovering();
    let t = motors_run(&mut c, 2000, 0.5, 6, 0, 0.0);
    assert_eq!(c.failed_motor(), Some(0));
    let status = c.status(Time(t));
    assert_eq!(status.failed_motor, Some(0));
    assert_eq!(status.last_refusal.as_deref(), Some("Motor 1 failure: flying on the others"));
    assert_eq!(status.failsafe, None, "five motors hold every axis: no failsafe");
    assert_eq!(c.mode(), FlightMode::PosHold);
    assert_eq!(c.update(Time(t)).failed_motor, Some(0));
}

#[test]
fn bad_or_stale_telemetry_is_never_judged_and_a_new_flight_starts_healthy() {
    let mut c = hovering();
    // NaN thrust is refused, not taken for a stopped motor.
    let t = motors_run(&mut c, 2000, 0.5, 4, 2, f64::NAN);
    assert_eq!(c.failed_motor(), None);
    // Telemetry with commands older than COMMAND_STALE_S: nothing to compare it with.
    let mut t = t;
    let stale = ActuatorOutputs { time: Time(t), armed: true, motors: [0.5; 8] };
    c.on_actuators(&stale);
    for _ in 0..200 {
        t += 2500;
        c.on_esc_telemetry(&EscTelemetry {
            time: Time(t + 30_000),
            count: 4,
            thrust: [0.0; 8],
            speed_rad_s: [0.0; 8],
        });
    }
    assert_eq!(c.failed_motor(), None);
    // A failure, then a landing and a new arming: the detector starts afresh.
    let t = motors_run(&mut c, t + 30_000, 0.5, 4, 3, 0.0);
    assert_eq!(c.failed_motor(), Some(3));
    cmd(&mut c, Command::Disarm { force: true }).expect("disarm");
    c.on_nav(&nav(Time(t), 0.0, true));
    c.on_battery(&full_battery(Time(t)));
    c.update(Time(t));
    at(&mut c, t, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    at(&mut c, t, Command::Arm).expect("arm");
    assert_eq!(c.failed_motor(), None);
}

/// The vehicle 20 m north of home at the RTL altitude, heading `yaw` (rad), at `t` µs.
fn at_north(t: u64, yaw: f64) -> NavState {
    let rtl_down = -CommanderParams::default().rtl_altitude_m;
    NavState { position_ned_m: [20.0, 0.0, rtl_down], ..nav_heading(t, rtl_down, yaw) }
}

/// A hovering commander 20 m north of home, facing north, told to return at 2.5 ms.
fn rtl_from_the_north() -> Commander {
    let mut c = hovering();
    c.on_nav(&at_north(2500, 0.0));
    at(&mut c, 2500, Command::ReturnToLaunch).expect("rtl");
    c
}

/// In RTL's return leg, 20 m north of home at the RTL altitude, with the avoider streaming
/// `frd` (stale when `stale`) from `stale_from` on; the nav heading follows the commanded yaw.
/// Returns the commander, the last setpoint and the time.
fn rtl_return(frd: [f64; 3], stale_from: Option<u64>, until: u64) -> (Commander, TrajectorySetpoint, u64) {
    let mut c = rtl_from_the_north();
    let (mut t, mut yaw, mut sp) = (2500, 0.0, TrajectorySetpoint::default());
    while t < until {
        t += 2500;
        c.on_nav(&at_north(t, yaw));
        c.on_avoidance(&avoidance(t, frd, stale_from.is_some_and(|s| t >= s)));
        sp = trajectory(c.update(Time(t)).target);
        yaw = sp.yaw_rad.expect("yaw");
    }
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch);
    (c, sp, t)
}

#[test]
fn rtl_flies_home_with_the_avoider_in_the_loop_facing_the_way_home() {
    // The avoider asks for 1 m/s to the right: once the nose faces home (south), right is west.
    let (c, sp, t) = rtl_return([0.0, 1.0, 0.0], None, 8_000_000);
    let speed = CommanderParams::default().rtl_speed_m_s;
    let yaw = sp.yaw_rad.expect("yaw");
    // Within a milliradian: the setpoint the bearing is taken from has moved a step west.
    assert!((yaw.abs() - std::f64::consts::PI).abs() < 1e-3, "the forward camera looks home: yaw {yaw}");
    let v = velocity(&sp);
    assert!((v[0] + speed).abs() < 1e-2 && (v[1] + 1.0).abs() < 1e-2 && v[2].abs() < 1e-6, "{v:?}");
    assert_eq!(c.status(Time(t)).last_refusal, None);
}

#[test]
fn rtl_started_facing_away_from_home_turns_before_it_flies_the_way_home() {
    // 20 m north of home facing north: home is behind. Until the nose is within 30° of south
    // the demand is a turn on the spot, with no horizontal velocity; then it flies home.
    let mut c = rtl_from_the_north();
    let (mut t, mut yaw) = (2500, 0.0);
    let mut flew_while_off = 0.0f64;
    let mut sp = TrajectorySetpoint::default();
    while t < 10_000_000 {
        t += 2500;
        c.on_nav(&at_north(t, yaw));
        c.on_avoidance(&avoidance(t, [0.0; 3], false));
        sp = trajectory(c.update(Time(t)).target);
        let off_home = (std::f64::consts::PI - yaw.abs()).abs();
        if off_home > 31f64.to_radians() {
            // The climb's setpoint is a position alone: no velocity demand at all.
            let [n, e, _] = sp.velocity_ned_m_s.map(|v| v.unwrap_or(0.0));
            flew_while_off = flew_while_off.max(n.hypot(e));
        }
        yaw = sp.yaw_rad.expect("yaw");
    }
    assert!(flew_while_off < 1e-9, "{flew_while_off} m/s with home out of view");
    let v = velocity(&sp);
    let speed = CommanderParams::default().rtl_speed_m_s;
    assert!((v[0] + speed).abs() < 1e-2 && v[1].abs() < 1e-2, "then home at the RTL speed: {v:?}");
}

#[test]
fn rtl_with_a_stale_avoider_slows_and_holds_and_says_why() {
    let (c, sp, t) = rtl_return([0.0; 3], Some(4_000_000), 9_000_000);
    assert_eq!(velocity(&sp), [0.0; 3], "held");
    assert!(c.avoidance_holding());
    let why = c.status(Time(t)).last_refusal.expect("says why");
    assert!(why.contains("avoidance stale"), "{why}");
}

#[test]
fn rtl_flies_home_at_the_height_an_avoider_climb_reached_not_back_down_onto_what_it_climbed_over() {
    // On the way home the avoider climbs 10 m over a tree taller than the RTL altitude (every
    // region blocked), then the climb ends with the vehicle above the tree's top. The forward
    // camera cannot see the top below: going back down to the RTL altitude would land on it.
    let mut c = rtl_from_the_north();
    let rtl_down = -CommanderParams::default().rtl_altitude_m;
    let top_down = rtl_down - 10.0;
    let (mut t, mut yaw, mut down) = (2500, 0.0, rtl_down);
    let mut sp = TrajectorySetpoint::default();
    while t < 17_000_000 {
        t += 2500;
        // Facing home from 4 s on; climbing at 1.5 m/s until 10 m up.
        let climbing = t > 4_000_000 && down > top_down;
        if climbing {
            down = (down - 1.5 * 0.0025).max(top_down);
        }
        c.on_nav(&NavState { position_ned_m: [20.0, 0.0, down], ..nav_heading(t, down, yaw) });
        let command = if climbing {
            let health = AvoidanceHealth { climbing: true, ..AvoidanceHealth::default() };
            AvoidanceCommand { health, ..avoidance(t, [0.0, 0.0, -1.5], false) }
        } else {
            avoidance(t, [0.0; 3], false)
        };
        c.on_avoidance(&command);
        sp = trajectory(c.update(Time(t)).target);
        yaw = sp.yaw_rad.expect("yaw");
    }
    assert!((down - top_down).abs() < 1e-9, "the climb reached the top: {down}");
    assert_eq!(c.mode(), FlightMode::ReturnToLaunch);
    // Seconds after the climb ended: home at the reached height, not down at 2 m/s.
    let v = velocity(&sp);
    assert!(v[2].abs() < 0.05, "no descent on the way home: {v:?}");
    let sp_down = sp.position_ned_m[2].expect("down");
    assert!((sp_down - top_down).abs() < 0.35, "held {sp_down} m against {top_down} m");
    assert!(v[0] < -1.0, "and flying home: {v:?}");
}

fn rangefinder(t: u64, orientation: RangefinderOrientation, distance_m: Option<f64>) -> RangefinderSample {
    RangefinderSample { time: Time(t), orientation, distance_m, min_range_m: 0.1, max_range_m: 12.0 }
}

#[test]
fn a_takeoff_under_something_overhead_stops_the_margin_below_it_and_ends_there_in_guided() {
    let mut c = ready(true);
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    cmd(&mut c, Command::Takeoff { altitude_m: 10.0 }).expect("takeoff");
    // Climbing through 2 m with a slab 6 m up: the target is 4 m, not 10 m, and the status says why.
    c.on_nav(&nav(Time(2000), -2.0, true));
    c.on_rangefinder(&rangefinder(2000, RangefinderOrientation::Up, Some(4.0)));
    let SetpointTarget::Trajectory(t) = c.update(Time(2000)).target else { panic!("trajectory expected") };
    assert_eq!(t.position_ned_m[2], Some(-4.0));
    let limit = c.status(Time(2000)).vertical_limit.expect("limited");
    assert_eq!(limit.kind, VerticalLimitKind::Overhead);
    assert!((limit.distance_m - 4.0).abs() < 1e-9);
    assert_eq!(c.mode(), FlightMode::Takeoff);
    // At 4 m under a slab seen for less than a second the take-off goes on (a passing return
    // only holds the climb); seen for a second, it is over and GUIDED holds there.
    let mut t = 2000;
    while t < 980_000 {
        t += 20_000;
        c.on_nav(&nav(Time(t), -4.0, true));
        c.on_rangefinder(&rangefinder(t, RangefinderOrientation::Up, Some(2.0)));
        c.update(Time(t));
        assert_eq!(c.mode(), FlightMode::Takeoff, "{t}");
    }
    t += 20_000;
    c.on_nav(&nav(Time(t), -4.0, true));
    c.on_rangefinder(&rangefinder(t, RangefinderOrientation::Up, Some(2.0)));
    c.update(Time(t));
    assert_eq!(c.mode(), FlightMode::Guided);
    // A GUIDED target above the slab is held below it too; a stale reading no longer limits.
    at(&mut c, t, Command::GotoNed { position_ned_m: [0.0, 0.0, -12.0] }).expect("goto");
    c.on_nav(&nav(Time(t), -4.0, true));
    let SetpointTarget::Trajectory(sp) = c.update(Time(t)).target else { panic!("trajectory expected") };
    assert_eq!(sp.position_ned_m[2], Some(-4.0));
    let later = t + 600_000;
    c.on_nav(&nav(Time(later), -4.0, true));
    let SetpointTarget::Trajectory(sp) = c.update(Time(later)).target else { panic!("trajectory expected") };
    assert_eq!(sp.position_ned_m[2], Some(-12.0));
    assert_eq!(c.status(Time(later)).vertical_limit, None);
}

#[test]
fn a_landing_over_an_obstacle_top_holds_above_it_and_moves_off_before_descending() {
    let mut c = hovering();
    // 10 m up, facing north, over a roof 4 m high.
    c.on_nav(&nav(Time(3000), -10.0, true));
    cmd(&mut c, Command::Land).expect("land");
    c.on_rangefinder(&rangefinder(3000, RangefinderOrientation::Down, Some(6.0)));
    let SetpointTarget::Trajectory(t) = c.update(Time(3000)).target else { panic!("trajectory expected") };
    assert_eq!(t.position_ned_m, [Some(-2.0), Some(0.0), Some(-10.0)], "{t:?}");
    assert_eq!(c.status(Time(3000)).vertical_limit.map(|l| l.kind), Some(VerticalLimitKind::ObstacleBelow));
    // Moved 2 m back, the ground 10 m below: one step more, then the descent.
    let mut over_ground = nav(Time(4000), -10.0, true);
    over_ground.position_ned_m = [-2.0, 0.0, -10.0];
    c.on_nav(&over_ground);
    c.on_rangefinder(&rangefinder(4000, RangefinderOrientation::Down, Some(10.0)));
    let SetpointTarget::Trajectory(t) = c.update(Time(4000)).target else { panic!("trajectory expected") };
    assert_eq!(t.position_ned_m, [Some(-4.0), Some(0.0), Some(-10.0)], "{t:?}");
    over_ground.time = Time(5000);
    over_ground.position_ned_m = [-4.0, 0.0, -10.0];
    c.on_nav(&over_ground);
    c.on_rangefinder(&rangefinder(5000, RangefinderOrientation::Down, Some(10.0)));
    let SetpointTarget::Trajectory(t) = c.update(Time(5000)).target else { panic!("trajectory expected") };
    assert_eq!(t.position_ned_m, [Some(-4.0), Some(0.0), None], "{t:?}");
    assert!(t.velocity_ned_m_s[2].is_some_and(|v| v > 0.0), "{t:?}");
    assert_eq!(c.status(Time(5000)).vertical_limit, None);
}

#[test]
fn without_a_fresh_rangefinder_reading_a_takeoff_climbs_as_before() {
    let mut c = ready(true);
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    cmd(&mut c, Command::Takeoff { altitude_m: 10.0 }).expect("takeoff");
    // A reading older than timeout_s says nothing.
    c.on_rangefinder(&rangefinder(1000, RangefinderOrientation::Up, Some(1.0)));
    c.on_nav(&nav(Time(600_000), -2.0, true));
    let SetpointTarget::Trajectory(t) = c.update(Time(600_000)).target else { panic!("trajectory expected") };
    assert_eq!(t.position_ned_m[2], Some(-10.0));
}

#[test]
fn holding_over_a_top_is_no_touchdown_and_a_silent_sensor_then_lands_where_it_is() {
    let mut c = hovering();
    c.on_nav(&nav(Time(3000), -10.0, true));
    cmd(&mut c, Command::Land).expect("land");
    let mut t = 3000;
    // Still 10 m up over a 4 m top for 3 s (the detector needs 1 s of stillness): armed, holding.
    while t < 3_000_000 {
        t += 2500;
        c.on_nav(&nav(Time(t), -10.0, true));
        c.on_rangefinder(&rangefinder(t, RangefinderOrientation::Down, Some(6.0)));
        c.update(Time(t));
    }
    assert!(c.armed(), "disarmed while holding over the top");
    assert_eq!(c.landed(), LandedState::InAir);
    // The sensor falls silent: the search ends and the descent starts where the vehicle is.
    t += 600_000;
    c.on_nav(&nav(Time(t), -10.0, true));
    let SetpointTarget::Trajectory(sp) = c.update(Time(t)).target else { panic!("trajectory expected") };
    assert!(sp.velocity_ned_m_s[2].is_some_and(|v| v > 0.0), "{sp:?}");
    c.update(Time(t));
    assert_eq!(c.landed(), LandedState::Landing);
}

#[test]
fn a_takeoff_with_no_room_overhead_stays_on_the_ground() {
    let mut c = ready(true);
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    cmd(&mut c, Command::Takeoff { altitude_m: 10.0 }).expect("takeoff");
    // A surface 2.5 m above the vehicle on the ground leaves 0.5 m under the margin.
    c.on_rangefinder(&rangefinder(1000, RangefinderOrientation::Up, Some(2.5)));
    assert_eq!(c.update(Time(1000)).target, SetpointTarget::MotorsOff);
    assert_eq!(c.mode(), FlightMode::Takeoff);
    assert_eq!(c.status(Time(1000)).vertical_limit.map(|l| l.kind), Some(VerticalLimitKind::Overhead));
}
