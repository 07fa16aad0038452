//! What the commander's tests share: navigation states, a commander ready to arm or hovering,
//! commands at a time, missions, sticks and avoider corrections.

use kestrel_proto::Time;
use kestrel_proto::geo::Geodetic;
use kestrel_proto::messages::{
    AltitudeFrame, AvoidanceCommand, AvoidanceHealth, BatteryStatus, ClearRange, ClearRangeReason, Command,
    FlightMode, LandedState, ManualControl, Mission, MissionItem, MissionPoint, NavState, NavValidity,
    SetpointTarget, TrajectorySetpoint, VehicleCommand,
};

use crate::commander::{Commander, CommanderParams};

/// A still, level NavState `down_m` (NED) at home, with or without a horizontal position.
/// The estimator's origin in every fixture.
pub(crate) const ORIGIN: Geodetic = Geodetic { lat_deg: 6.79710, lon_deg: 79.90170, alt_m: 20.0 };

pub(crate) fn nav(t: Time, down_m: f64, position: bool) -> NavState {
    NavState {
        time: t,
        attitude: [1.0, 0.0, 0.0, 0.0],
        angular_velocity_rad_s: [0.0; 3],
        velocity_ned_m_s: [0.0; 3],
        position_ned_m: [0.0, 0.0, down_m],
        gyro_bias_rad_s: [0.0; 3],
        accel_bias_m_s2: [0.0; 3],
        covariance_diagonal: [0.0; 16],
        origin: position.then_some(ORIGIN),
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

pub(crate) fn mission() -> Mission {
    let point =
        MissionPoint { lat_deg: 6.7972, lon_deg: 79.9017, alt_m: 10.0, frame: AltitudeFrame::RelativeHome };
    Mission {
        time: Time::ZERO,
        items: vec![MissionItem::Takeoff { point }, MissionItem::ReturnToLaunch],
        cruise_speed_m_s: 5.0,
    }
}

/// A commander with fresh navigation (with or without position) and a full battery.
pub(crate) fn ready(position: bool) -> Commander {
    let mut c = Commander::new(CommanderParams::default()).expect("valid");
    c.on_nav(&nav(Time(1000), 0.0, position));
    c.on_battery(&full_battery(Time(1000)));
    c
}

/// A fresh battery, as the pre-arm checks want it.
pub(crate) fn full_battery(time: Time) -> BatteryStatus {
    BatteryStatus { time, voltage_v: 16.4, current_a: 1.0, consumed_mah: 0.0, remaining: 1.0 }
}

pub(crate) fn cmd(c: &mut Commander, command: Command) -> Result<(), String> {
    c.on_command(&VehicleCommand { id: 0, time: Time(1000), command }).map_err(|r| r.0)
}

/// Armed in POSHOLD and in the air 5 m above home at t = 2 ms.
pub(crate) fn hovering() -> Commander {
    let mut c = ready(true);
    cmd(&mut c, Command::SetMode(FlightMode::PosHold)).expect("poshold");
    cmd(&mut c, Command::Arm).expect("arm");
    c.on_nav(&nav(Time(2000), -5.0, true));
    c.update(Time(2000));
    assert_eq!(c.landed(), LandedState::InAir);
    c
}

pub(crate) fn at(c: &mut Commander, t: u64, command: Command) -> Result<(), String> {
    c.on_command(&VehicleCommand { id: 0, time: Time(t), command }).map_err(|r| r.0)
}

/// A command whose view vouches for 100 m ahead: far enough that the speed cap never bites.
pub(crate) fn avoidance(t: u64, frd: [f64; 3], stale: bool) -> AvoidanceCommand {
    AvoidanceCommand {
        time: Time(t),
        velocity_frd_m_s: frd,
        health: AvoidanceHealth { stale, ..AvoidanceHealth::default() },
        clear_range: ClearRange { range_m: 100.0, reason: ClearRangeReason::StereoRange },
        ..AvoidanceCommand::default()
    }
}

/// `nav` at `down_m`, heading `yaw_rad`.
pub(crate) fn nav_heading(t: u64, down_m: f64, yaw_rad: f64) -> NavState {
    let (s, c) = (yaw_rad / 2.0).sin_cos();
    NavState { attitude: [c, 0.0, 0.0, s], ..nav(Time(t), down_m, true) }
}

pub(crate) fn trajectory(target: SetpointTarget) -> TrajectorySetpoint {
    match target {
        SetpointTarget::Trajectory(sp) => sp,
        other => panic!("not a trajectory: {other:?}"),
    }
}

pub(crate) fn velocity(sp: &TrajectorySetpoint) -> [f64; 3] {
    sp.velocity_ned_m_s.map(|v| v.expect("velocity demand"))
}

pub(crate) fn sticks(t: u64, roll: f64, pitch: f64, yaw: f64, throttle: f64) -> ManualControl {
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
pub(crate) fn fly_sticks(
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

/// A point `north_m` north of the origin (about 110.6 km per degree here), `alt_m` in `frame`.
pub(crate) fn point_north(north_m: f64, alt_m: f64, frame: AltitudeFrame) -> MissionPoint {
    MissionPoint { lat_deg: 6.79710 + north_m / 110_600.0, lon_deg: 79.90170, alt_m, frame }
}

pub(crate) fn hover_at(c: &mut Commander, t: u64, position_ned_m: [f64; 3]) -> SetpointTarget {
    c.on_nav(&NavState { position_ned_m, ..nav(Time(t), position_ned_m[2], true) });
    c.update(Time(t)).target
}

/// Three waypoints 20, 40 and 60 m north of home at 10 m.
pub(crate) fn three_waypoints() -> Mission {
    let wp = |north_m| MissionItem::Waypoint {
        point: point_north(north_m, 10.0, AltitudeFrame::RelativeHome),
        acceptance_radius_m: 1.0,
        hold_s: 0.0,
    };
    Mission { time: Time::ZERO, items: vec![wp(20.0), wp(40.0), wp(60.0)], cruise_speed_m_s: 5.0 }
}

/// The vehicle 20 m north of home at the RTL altitude, heading `yaw` (rad), at `t` µs.
pub(crate) fn at_north(t: u64, yaw: f64) -> NavState {
    let rtl_down = -CommanderParams::default().rtl_altitude_m;
    NavState { position_ned_m: [20.0, 0.0, rtl_down], ..nav_heading(t, rtl_down, yaw) }
}

/// A hovering commander 20 m north of home, facing north, told to return at 2.5 ms.
pub(crate) fn rtl_from_the_north() -> Commander {
    let mut c = hovering();
    c.on_nav(&at_north(2500, 0.0));
    at(&mut c, 2500, Command::ReturnToLaunch).expect("rtl");
    c
}
